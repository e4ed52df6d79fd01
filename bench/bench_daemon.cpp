// The daemon's cost: a request's round trip through `hdrd serve` (Unix socket, HTTP,
// queue, worker hand-offs, response) versus the same work in-process (render 256x256 with
// the renderer, encode HDR10, PNG; and an EXR upload to POST /v1/encode against the same
// frame job in-process), a bare GET round trip, and throughput with 1, 2, 4 and 8
// concurrent clients. Results: docs/performance-daemon.md, docs/performance.md.
//
//   build/bench/bench_daemon --benchmark_min_time=2
//   HDRD_BINARY=path/to/hdrd overrides where the daemon program is looked for;
//   HDRD_BENCH_EXR=IN.exr is the upload of BM_EncodeOverhead_Interleaved (skipped without).
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "clients/cpp/client.hpp"
#include "encode/io/io.hpp"
#include "job/frame_job.hpp"
#include "job/request.hpp"
#include "encode/pipeline.hpp"
#include "shading/renderer.hpp"

namespace {

namespace fs = std::filesystem;
constexpr int kSize = 256;
const std::string kBody = fmt::format(R"({{"width":{0},"height":{0},"display":{{"mode":"hdr10","peak_nits":1000}}}})", kSize);

fs::path hdrd_program() {
  if (const char* p = std::getenv("HDRD_BINARY")) return p;
  return fs::canonical("/proc/self/exe").parent_path().parent_path() / "tools/hdrd";
}

// One daemon for the whole run: 1 render worker (one GL context, like the in-process
// renderer), 1 encode thread (so an encode uses every core, like an in-process call).
class Daemon {
 public:
  Daemon(int render_workers, int encode_threads) {
    dir_ = fs::temp_directory_path() / fmt::format("hdrd-bench-{}-{}", ::getpid(), render_workers);
    fs::create_directories(dir_);
    socket_ = (dir_ / "hdrd.sock").string();
    std::ofstream(dir_ / "hdrd.toml") << fmt::format(
        "[server]\nsocket_path = \"{}\"\nmax_connections = 64\n[workers]\nrender_workers = {}\nencode_threads = {}\n"
        "queue_depth = 64\ncoalesce = false\n[log]\nlevel = \"warn\"\naccess_log = false\n",
        socket_, render_workers, encode_threads);
    const std::string prog = hdrd_program().string(), cfg = (dir_ / "hdrd.toml").string();
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open((dir_ / "daemon.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::execl(prog.c_str(), prog.c_str(), "serve", "--config", cfg.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    for (int i = 0; i < 3000; ++i) {
      auto c = client();
      auto r = c.request("GET", "/v1/status");
      if (r && r->status == 200) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::fprintf(stderr, "bench_daemon: %s did not start\n", prog.c_str());
    std::exit(1);
  }
  ~Daemon() {
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  hdrd::daemon::Client client() const {
    hdrd::daemon::ClientOptions o;
    o.socket_path = socket_;
    return hdrd::daemon::Client(o);
  }

 private:
  fs::path dir_;
  std::string socket_;
  pid_t pid_ = -1;
};

Daemon& single_worker_daemon() {
  static Daemon d(1, 1);
  return d;
}
// Throughput daemons: 1 render worker (the default configuration) or 2, and 2 encode
// threads (the default); started on first use, one per worker count.
Daemon& throughput_daemon(int render_workers) {
  static std::map<int, std::unique_ptr<Daemon>> daemons;
  auto& d = daemons[render_workers];
  if (!d) d = std::make_unique<Daemon>(render_workers, 2);
  return *d;
}

// The same work as POST /v1/render with that body and Accept: image/png, timed by stage.
struct LocalFrame {
  std::vector<std::uint8_t> png;
  double render_ms = 0, encode_ms = 0, png_ms = 0;
};

hdrd::Result<LocalFrame> local_frame(hdrd::shading::Renderer& renderer) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  hdrd::shading::RenderRequest rq;
  rq.scene = hdrd::shading::default_scene_name();
  rq.width = rq.height = kSize;
  rq.samples = 1;
  rq.load.allow_files = false;
  auto r = renderer.render(rq);
  if (!r) return r.error();
  const auto t1 = clock::now();
  hdrd::SceneInput in;
  in.image = &r->scene_nits;
  in.units = hdrd::InputUnits::absolute;
  in.illuminance_lux = r->dominant_illuminance_lux;
  hdrd::EncodeSettings s;
  s.target = hdrd::default_target(hdrd::Mode::hdr10);
  s.exposure.mode = hdrd::exposure::Mode::light;
  auto frame = hdrd::encode_frame(in, s);
  if (!frame) return frame.error();
  const auto t2 = clock::now();
  auto png = hdrd::io::encode_png(*frame);
  if (!png) return png.error();
  const auto t3 = clock::now();
  auto ms = [](clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  return LocalFrame{std::move(*png), ms(t1 - t0), ms(t2 - t1), ms(t3 - t2)};
}

void BM_InProcess_Render256Png(benchmark::State& state) {
  auto renderer = hdrd::shading::Renderer::create();
  if (!renderer) {
    state.SkipWithError(renderer.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    auto f = local_frame(**renderer);
    if (!f) {
      state.SkipWithError(f.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(f->png.data());
  }
}
BENCHMARK(BM_InProcess_Render256Png)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Daemon_Render256Png(benchmark::State& state) {
  auto c = single_worker_daemon().client();
  for (auto _ : state) {
    auto r = c.request("POST", "/v1/render", kBody, {{"Content-Type", "application/json"}, {"Accept", "image/png"}});
    if (!r || r->status != 200) {
      state.SkipWithError("render request failed");
      return;
    }
    benchmark::DoNotOptimize(r->body.data());
  }
}
BENCHMARK(BM_Daemon_Render256Png)->Unit(benchmark::kMillisecond)->UseRealTime();

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

double header_ms(const hdrd::daemon::ClientResponse& r, const char* name) {
  const std::string* v = r.header(name);
  return v ? std::stod(*v) : 0.0;
}

// The medians of the in-process and daemon times of the alternated pairs, and their
// difference: the daemon's overhead.
void overhead_counters(benchmark::State& state, const std::vector<double>& local_ms, const std::vector<double>& daemon_ms) {
  const double l = median(local_ms), dm = median(daemon_ms);
  state.counters["inprocess_ms"] = l;
  state.counters["daemon_ms"] = dm;
  state.counters["overhead_ms"] = dm - l;
  state.counters["overhead_pct"] = l > 0 ? 100.0 * (dm - l) / l : 0;
}

// The comparison that matters on a shared machine: alternate one in-process frame and one
// daemon round trip, so that background load hits both alike; report the medians and the
// difference (the daemon's overhead). The daemon's own X-Hdrd-Render-Ms / X-Hdrd-Encode-Ms
// split its time: what is left (daemon_other_ms) is the socket, HTTP, queue and hand-offs
// plus the PNG serialisation (inprocess_png_ms in-process).
void BM_Overhead_Interleaved(benchmark::State& state) {
  auto renderer = hdrd::shading::Renderer::create();
  if (!renderer) {
    state.SkipWithError(renderer.error().message.c_str());
    return;
  }
  auto c = single_worker_daemon().client();
  std::vector<double> local_ms, daemon_ms, local_render, local_encode, local_png, daemon_render, daemon_encode,
      daemon_other, transport;
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    auto t0 = clock::now();
    auto f = local_frame(**renderer);
    auto t1 = clock::now();
    auto d = c.request("POST", "/v1/render", kBody, {{"Content-Type", "application/json"}, {"Accept", "image/png"}});
    auto t2 = clock::now();
    if (!f || !d || d->status != 200 || d->body.size() != f->png.size()) {
      static std::string why;  // SkipWithError keeps the pointer
      why = fmt::format("daemon answer ({} bytes, HTTP {}) differs from the in-process frame ({} bytes)",
                        d ? d->body.size() : 0, d ? d->status : 0, f ? f->png.size() : 0);
      state.SkipWithError(why.c_str());
      return;
    }
    local_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    daemon_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    local_render.push_back(f->render_ms);
    local_encode.push_back(f->encode_ms);
    local_png.push_back(f->png_ms);
    daemon_render.push_back(header_ms(*d, "x-hdrd-render-ms"));
    daemon_encode.push_back(header_ms(*d, "x-hdrd-encode-ms"));
    daemon_other.push_back(daemon_ms.back() - daemon_render.back() - daemon_encode.back());
    transport.push_back(daemon_other.back() - f->png_ms);
  }
  overhead_counters(state, local_ms, daemon_ms);
  state.counters["inprocess_render_ms"] = median(local_render);
  state.counters["inprocess_encode_ms"] = median(local_encode);
  state.counters["inprocess_png_ms"] = median(local_png);
  state.counters["daemon_render_ms"] = median(daemon_render);
  state.counters["daemon_encode_ms"] = median(daemon_encode);
  state.counters["daemon_other_ms"] = median(daemon_other);
  // Paired per iteration: the daemon's time outside render, encode and PNG serialisation.
  state.counters["transport_ms"] = median(transport);
}
BENCHMARK(BM_Overhead_Interleaved)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(100);

// An EXR upload (HDRD_BENCH_EXR, e.g. bench/run-io.sh's 4K file) answered as an HDR10 PNG:
// POST /v1/encode?mode=hdr10 against the same frame job in this process (the request
// parsed the same way, the file's bytes already in memory on both sides: decode, meter,
// encode, PNG), alternated, medians. The difference is the daemon's own cost: the upload
// and the answer through the socket, HTTP, the queue and the hand-offs.
void BM_EncodeOverhead_Interleaved(benchmark::State& state) {
  const char* path = std::getenv("HDRD_BENCH_EXR");
  if (!path) {
    state.SkipWithError("set HDRD_BENCH_EXR to an EXR file");
    return;
  }
  std::ifstream f(path, std::ios::binary);
  const std::string exr((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (exr.empty()) {
    state.SkipWithError("HDRD_BENCH_EXR: cannot read the file");
    return;
  }
  auto local = [&]() -> hdrd::Result<std::vector<std::uint8_t>> {
    hdrd::job::ParseContext ctx;
    ctx.source = hdrd::job::Source::encode;
    ctx.reach = hdrd::job::Reach::daemon;
    auto request = hdrd::job::parse_request_json(nlohmann::json{{"display", {{"mode", "hdr10"}}}}, ctx);
    if (!request) return request.error();
    hdrd::job::EncodeInput input;
    input.bytes = exr;  // the daemon's side starts from bytes in memory too
    input.name = "upload";
    auto job = hdrd::job::FrameJob::create(std::move(*request), {}, std::move(input), std::vector{hdrd::job::Output::png});
    if (!job) return job.error();
    auto result = (*job)->finish();
    if (!result) return result.error();
    return std::move(result->files.at(0).bytes);
  };
  auto c = single_worker_daemon().client();
  std::vector<double> local_ms, daemon_ms, daemon_encode;
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  for (auto _ : state) {
    const auto t0 = clock::now();
    auto png = local();
    const auto t1 = clock::now();
    auto d = c.request("POST", "/v1/encode?mode=hdr10", exr, {{"Content-Type", "image/x-exr"}, {"Accept", "image/png"}});
    const auto t2 = clock::now();
    if (!png || !d || d->status != 200 || d->body.size() != png->size()) {
      static std::string why;  // SkipWithError keeps the pointer
      why = fmt::format("daemon answer ({} bytes, HTTP {}) differs from the in-process PNG ({} bytes{})", d ? d->body.size() : 0,
                        d ? d->status : 0, png ? png->size() : 0, png ? "" : ": " + png.error().message);
      state.SkipWithError(why.c_str());
      return;
    }
    local_ms.push_back(ms(t1 - t0));
    daemon_ms.push_back(ms(t2 - t1));
    daemon_encode.push_back(header_ms(*d, "x-hdrd-encode-ms"));
  }
  overhead_counters(state, local_ms, daemon_ms);
  state.counters["daemon_encode_ms"] = median(daemon_encode);
  state.counters["upload_mb"] = exr.size() / 1e6;
}
BENCHMARK(BM_EncodeOverhead_Interleaved)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(20);

// The transport alone: a GET answered on the HTTP thread (no queue, no workers).
void BM_Daemon_StatusRoundTrip(benchmark::State& state) {
  auto c = single_worker_daemon().client();
  for (auto _ : state) {
    auto r = c.request("GET", "/v1/status");
    benchmark::DoNotOptimize(r->body.data());
  }
}
BENCHMARK(BM_Daemon_StatusRoundTrip)->Unit(benchmark::kMicrosecond)->UseRealTime();

// A request that goes through the queue and the encode pool but does almost no work:
// a 4-byte "EXR" that the decoder refuses at once.
void BM_Daemon_QueuedNoWorkRoundTrip(benchmark::State& state) {
  auto c = single_worker_daemon().client();
  const std::string tiny("\x76\x2f\x31\x01", 4);
  for (auto _ : state) {
    auto r = c.request("POST", "/v1/encode", tiny, {{"Content-Type", "image/x-exr"}});
    benchmark::DoNotOptimize(r->status);
  }
}
BENCHMARK(BM_Daemon_QueuedNoWorkRoundTrip)->Unit(benchmark::kMicrosecond)->UseRealTime();

// Throughput: N clients, each on its own connection, send kThroughputRequests renders in
// all to a daemon with R render workers and 2 encode threads; requests per second is that
// count over the wall time from the first send to the last answer, latency the median round
// trip. (Counted here rather than with Google Benchmark's per-thread counters, whose sums
// and rates are easy to misread for threaded runs.)
constexpr int kThroughputRequests = 96;

void BM_Daemon_Throughput(benchmark::State& state) {
  const int clients = int(state.range(0));
  const int render_workers = int(state.range(1));
  auto& daemon = throughput_daemon(render_workers);
  std::vector<double> latency_ms;
  std::mutex mu;
  std::atomic<int> failures{0};
  double wall_s = 0;
  for (auto _ : state) {
    latency_ms.clear();
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    for (int i = 0; i < clients; ++i)
      threads.emplace_back([&] {
        auto c = daemon.client();
        for (int k = 0; k < kThroughputRequests / clients; ++k) {
          const auto s = std::chrono::steady_clock::now();
          auto r = c.request("POST", "/v1/render", kBody, {{"Content-Type", "application/json"}, {"Accept", "image/png"}});
          const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s).count();
          if (!r || r->status != 200) ++failures;
          std::lock_guard lock(mu);
          latency_ms.push_back(ms);
        }
      });
    for (auto& t : threads) t.join();
    wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  if (failures) state.SkipWithError("render requests failed");
  state.counters["clients"] = clients;
  state.counters["render_workers"] = render_workers;
  state.counters["requests_per_s"] = kThroughputRequests / wall_s;
  state.counters["latency_median_ms"] = median(latency_ms);
}
BENCHMARK(BM_Daemon_Throughput)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)
    ->ArgNames({"clients", "render_workers"})
    ->ArgsProduct({{1, 2, 4, 8}, {1, 2}});

}  // namespace

BENCHMARK_MAIN();

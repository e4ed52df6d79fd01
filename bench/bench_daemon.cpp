// The daemon's cost: a request's round trip through `hdrd serve` (Unix socket, HTTP,
// queue, worker hand-offs, response) versus the same work in-process (render 256x256 with
// the renderer, encode HDR10, PNG), a bare GET round trip, and throughput with 1, 2, 4
// and 8 concurrent clients. Results: docs/performance-daemon.md.
//
//   build/bench/bench_daemon --benchmark_min_time=2
//   HDRD_BINARY=path/to/hdrd overrides where the daemon program is looked for.
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
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "daemon/client.hpp"
#include "encode/io.hpp"
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
Daemon& throughput_daemon() {
  static Daemon d(2, 2);
  return d;
}

// The same work as POST /v1/render with that body and Accept: image/png.
void BM_InProcess_Render256Png(benchmark::State& state) {
  auto renderer = hdrd::shading::Renderer::create();
  if (!renderer) {
    state.SkipWithError(renderer.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    hdrd::shading::RenderRequest rq;
    rq.scene = hdrd::shading::default_scene_name();
    rq.width = rq.height = kSize;
    rq.samples = 1;
    rq.load.allow_files = false;
    auto r = (*renderer)->render(rq);
    if (!r) {
      state.SkipWithError(r.error().message.c_str());
      return;
    }
    hdrd::SceneInput in;
    in.image = &r->scene_nits;
    in.units = hdrd::InputUnits::absolute;
    in.illuminance_lux = r->dominant_illuminance_lux;
    hdrd::EncodeSettings s;
    s.target = hdrd::default_target(hdrd::Mode::hdr10);
    s.exposure.mode = hdrd::exposure::Mode::light;
    auto frame = hdrd::encode_frame(in, s);
    auto png = hdrd::io::encode_png(*frame);
    benchmark::DoNotOptimize(png->data());
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

// The comparison that matters on a shared machine: alternate one in-process frame and one
// daemon round trip, so that background load hits both alike; report the medians and the
// difference (the daemon's overhead).
void BM_Overhead_Interleaved(benchmark::State& state) {
  auto renderer = hdrd::shading::Renderer::create();
  if (!renderer) {
    state.SkipWithError(renderer.error().message.c_str());
    return;
  }
  auto c = single_worker_daemon().client();
  std::vector<double> local_ms, daemon_ms;
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    auto t0 = clock::now();
    hdrd::shading::RenderRequest rq;
    rq.scene = hdrd::shading::default_scene_name();
    rq.width = rq.height = kSize;
    rq.samples = 1;
    rq.load.allow_files = false;
    auto r = (*renderer)->render(rq);
    hdrd::SceneInput in;
    in.image = &r->scene_nits;
    in.units = hdrd::InputUnits::absolute;
    in.illuminance_lux = r->dominant_illuminance_lux;
    hdrd::EncodeSettings s;
    s.target = hdrd::default_target(hdrd::Mode::hdr10);
    s.exposure.mode = hdrd::exposure::Mode::light;
    auto frame = hdrd::encode_frame(in, s);
    auto png = hdrd::io::encode_png(*frame);
    benchmark::DoNotOptimize(png->data());
    auto t1 = clock::now();
    auto d = c.request("POST", "/v1/render", kBody, {{"Content-Type", "application/json"}, {"Accept", "image/png"}});
    auto t2 = clock::now();
    if (!d || d->status != 200 || d->body.size() != png->size()) {
      state.SkipWithError("daemon answer differs from the in-process frame");
      return;
    }
    local_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    daemon_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  const double l = median(local_ms), dm = median(daemon_ms);
  state.counters["inprocess_ms"] = l;
  state.counters["daemon_ms"] = dm;
  state.counters["overhead_ms"] = dm - l;
  state.counters["overhead_pct"] = l > 0 ? 100.0 * (dm - l) / l : 0;
}
BENCHMARK(BM_Overhead_Interleaved)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(40);

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

// Throughput: N clients, each with its own connection, 2 render workers, 2 encode threads.
void BM_Daemon_Throughput(benchmark::State& state) {
  auto c = throughput_daemon().client();
  for (auto _ : state) {
    auto r = c.request("POST", "/v1/render", kBody, {{"Content-Type", "application/json"}, {"Accept", "image/png"}});
    if (!r || r->status != 200) {
      state.SkipWithError("render request failed");
      return;
    }
  }
  state.counters["requests_per_s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Daemon_Throughput)->Unit(benchmark::kMillisecond)->UseRealTime()->Threads(1)->Threads(2)->Threads(4)->Threads(8);

}  // namespace

BENCHMARK_MAIN();

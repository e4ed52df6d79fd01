// Frame I/O, stage by stage, in one process (bench/run-io.sh runs it beside the whole
// commands): reading the EXR (float and half), encoding, each writer of the dump with its
// file, the sidecar, and atomic writes with and without fsync. Stages run in a shuffled
// order every repetition, so a slow spell of the machine does not fall on one stage;
// medians in milliseconds, one JSON object on stdout: "ms" wall time, "cpu_ms" the
// process's CPU time (user + system, all threads), which a busy shared machine inflates
// far less than wall time.
//
//   bench_io IN.exr OUTDIR [--reps N] [--threads N] [--levels]
// --levels adds the HDR10 and SDR PNG at every level (time and size), for the table in
// docs/dump-format.md "PNG compression".
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <sys/resource.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

template <typename T>
T must(Result<T> r, const char* what) {
  if (!r) {
    std::fprintf(stderr, "bench_io: %s: %s\n", what, r.error().message.c_str());
    std::exit(1);
  }
  return std::move(r.value());
}
void must(Result<void> r, const char* what) {
  if (!r) {
    std::fprintf(stderr, "bench_io: %s: %s\n", what, r.error().message.c_str());
    std::exit(1);
  }
}

EncodedFrame encode(const io::ExrImage& exr, Mode mode, bool display_nits, int threads) {
  EncodeSettings s;
  s.target = default_target(mode);
  s.keep_display_nits = display_nits;
  s.threads = threads;
  SceneInput in;
  if (exr.holds_half()) in.half = &exr.half;
  else in.image = &exr.image;
  in.to_working = exr.to_working();
  return must(encode_frame(in, s), "encode");
}

double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e3;
}

void clear(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir)) fs::remove(e.path());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_io IN.exr OUTDIR [--reps N] [--threads N]\n");
    return 2;
  }
  const fs::path input = argv[1], dir = argv[2];
  int reps = 5, threads = 0;
  bool levels = false;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--levels") levels = true;
    else if (a == "--reps" && i + 1 < argc) reps = std::stoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) threads = std::stoi(argv[++i]);
  }
  fs::create_directories(dir);
  const io::ExrImage exr = must(io::read_exr(input), "read");
  const io::ExrImage exr_half = must(io::read_exr(input, {.half_pixels = true}), "read half");
  const EncodedFrame hdr10 = encode(exr_half, Mode::hdr10, true, threads);
  const EncodedFrame sdr = encode(exr_half, Mode::sdr, false, threads);
  const io::PngOptions png{.level = io::kDefaultPngLevel, .threads = threads};
  const io::DumpOptions dump{.png = png, .write = {}};
  const auto sidecar = io::sidecar_json(hdr10, {{"png", "x.png"}}).dump(2) + "\n";

  std::map<std::string, std::function<void()>> stages{
      {"read_exr_float", [&] { must(io::read_exr(input), "read"); }},
      {"read_exr_half", [&] { must(io::read_exr(input, {.half_pixels = true}), "read"); }},
      {"encode_hdr10_from_float", [&] { encode(exr, Mode::hdr10, false, threads); }},
      {"encode_hdr10_from_half", [&] { encode(exr_half, Mode::hdr10, false, threads); }},
      {"encode_hdr10_from_half_keep_nits", [&] { encode(exr_half, Mode::hdr10, true, threads); }},
      {"png_hdr10_bytes", [&] { must(io::encode_png(hdr10, png), "png"); }},
      {"png_sdr_bytes", [&] { must(io::encode_png(sdr, png), "png"); }},
      {"dump_png_hdr10", [&] { must(io::write_dumps(hdr10, dir / "a", {io::DumpFormat::png}, {}, dump), "dump"); }},
      {"dump_png_sdr", [&] { must(io::write_dumps(sdr, dir / "a", {io::DumpFormat::png}, {}, dump), "dump"); }},
      {"dump_exr", [&] { must(io::write_dumps(hdr10, dir / "a", {io::DumpFormat::exr}, {}, dump), "dump"); }},
      {"dump_raw", [&] { must(io::write_dumps(hdr10, dir / "a", {io::DumpFormat::raw}, {}, dump), "dump"); }},
      {"dump_all", [&] { must(io::write_dumps(hdr10, dir / "a", {}, {}, dump), "dump"); }},
      {"sidecar_json", [&] { (void)io::sidecar_json(hdr10, {{"png", "x.png"}}).dump(2); }},
      {"atomic_write_raw", [&] { must(io::atomic_write(dir / "r.raw", hdr10.data), "write"); }},
      {"atomic_write_raw_durable",
       [&] { must(io::atomic_write(dir / "r.raw", hdr10.data, {.durable = true}), "write"); }},
      {"atomic_write_sidecar",
       [&] {
         must(io::atomic_write(dir / "s.json",
                               std::span(reinterpret_cast<const std::uint8_t*>(sidecar.data()), sidecar.size())),
              "write");
       }},
  };
  nlohmann::json sizes;
  if (levels)
    for (int level = io::kMinPngLevel; level <= io::kMaxPngLevel; ++level)
      for (const auto* f : {&hdr10, &sdr}) {
        const std::string name = fmt::format("png_{}_level{}", f == &hdr10 ? "hdr10" : "sdr", level);
        const io::PngOptions o{.level = level, .threads = threads};
        stages[name] = [f, o] { must(io::encode_png(*f, o), "png"); };
        sizes[name] = must(io::encode_png(*f, o), "png").size();
      }
  std::vector<std::string> order;
  for (const auto& [name, fn] : stages) order.push_back(name);
  std::map<std::string, std::vector<double>> times, cpu;
  std::mt19937 rng(12345);
  for (int r = 0; r < reps; ++r) {
    std::shuffle(order.begin(), order.end(), rng);
    for (const auto& name : order) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_ms();
      stages[name]();
      times[name].push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      cpu[name].push_back(cpu_ms() - c0);
      clear(dir);
    }
  }
  nlohmann::json out;
  out["width"] = exr.width();
  out["height"] = exr.height();
  out["reps"] = reps;
  for (const auto& [name, v] : times) out["ms"][name] = std::round(median(v) * 10) / 10;
  for (const auto& [name, v] : cpu) out["cpu_ms"][name] = std::round(median(v) * 10) / 10;
  out["png_hdr10_bytes"] = must(io::encode_png(hdr10, png), "png").size();
  out["png_sdr_bytes"] = must(io::encode_png(sdr, png), "png").size();
  if (levels) out["level_bytes"] = sizes;
  std::printf("%s\n", out.dump().c_str());
}

// Renderer benchmarks (docs/performance.md): frame time of the material-grid and hdr
// scenes at 1920x1080 and 3840x2160, readback cost, the GPU encode pass against the
// render pass, and the peak resident memory after a 4K frame.
//   LP_NUM_THREADS=2 build/bench/bench_render --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdlib>
#include <memory>

#include "shading/gpu_encode.hpp"
#include "shading/renderer.hpp"

namespace {

using namespace hdrd;
using namespace hdrd::shading;

// llvmpipe's rasteriser threads: the project's machines have 2 vCPUs.
const bool kThreads = [] { return setenv("LP_NUM_THREADS", "2", 0) == 0; }();

Renderer* renderer() {
  static std::unique_ptr<Renderer> r = [] {
    auto c = Renderer::create(Backend::automatic);
    return c ? std::move(*c) : nullptr;
  }();
  return r.get();
}

const char* kScenes[] = {"material-grid", "hdr"};

double maxrss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;  // KiB on Linux
}

// Whole frames: scene set-up, shadow pass, lit pass with 4x MSAA, resolve, float readback.
void BM_Render(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  RenderRequest q;
  q.scene = kScenes[state.range(0)];
  q.width = static_cast<int>(state.range(1));
  q.height = static_cast<int>(state.range(2));
  q.samples = 4;
  if (!r->render(q).ok()) return state.SkipWithError("render failed");  // warm-up: shader variants
  double gpu = 0, readback = 0;
  for (auto _ : state) {
    auto f = r->render(q);
    if (!f) return state.SkipWithError(f.error().message.c_str());
    gpu += f->render_ms;
    readback += f->readback_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["render_ms"] = gpu / n;
  state.counters["readback_f32_ms"] = readback / n;
  state.counters["maxrss_MiB"] = maxrss_mib();
  state.SetLabel(std::string(q.scene) + " on " + r->context().gl_renderer());
}
BENCHMARK(BM_Render)
    ->ArgsProduct({{0, 1}, {1920}, {1080}})
    ->Args({0, 3840, 2160})
    ->Args({1, 3840, 2160})
    ->ArgNames({"scene", "w", "h"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();

// Peak resident memory of a 4K frame by sample count and target format. maxrss is a
// process high-water mark: run each case alone, e.g.
//   bench_render --benchmark_filter='BM_Memory4k/samples:1/fp16:0'
void BM_Memory4k(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  RenderRequest q;
  q.scene = "material-grid";
  q.width = 3840;
  q.height = 2160;
  q.samples = static_cast<int>(state.range(0));
  q.target = state.range(1) ? TargetFormat::rgba16f : TargetFormat::rgba32f;
  const double before = maxrss_mib();
  double gpu = 0;
  for (auto _ : state) {
    auto f = r->render(q);
    if (!f) return state.SkipWithError(f.error().message.c_str());
    gpu += f->render_ms;
  }
  state.counters["render_ms"] = gpu / static_cast<double>(state.iterations());
  state.counters["maxrss_before_MiB"] = before;
  state.counters["maxrss_MiB"] = maxrss_mib();
}
BENCHMARK(BM_Memory4k)
    ->ArgsProduct({{1, 4}, {0, 1}})
    ->ArgNames({"samples", "fp16"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

// The GPU encode pass (HDR10, default tone curve) over the frame still on the GPU,
// including the packed 10-bit readback, compared with the frame's render time.
void BM_EncodePass(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  RenderRequest q;
  q.scene = kScenes[state.range(0)];
  q.width = static_cast<int>(state.range(1));
  q.height = static_cast<int>(state.range(2));
  auto frame = r->render(q);
  if (!frame) return state.SkipWithError(frame.error().message.c_str());
  SceneInput in;
  in.image = &frame->scene_nits;
  in.units = InputUnits::absolute;
  in.illuminance_lux = frame->dominant_illuminance_lux;
  EncodeSettings s;
  s.png_samples = false;  // the scan-out buffer only
  auto prepared = prepare_pipeline(in, s);
  if (!prepared) return state.SkipWithError(prepared.error().message.c_str());
  auto enc = GpuEncoder::create(*r, *prepared);
  if (!enc) return state.SkipWithError(enc.error().message.c_str());
  if (!(*enc)->encode().ok()) return state.SkipWithError("encode failed");  // warm-up
  double pass = 0, readback = 0;
  for (auto _ : state) {
    auto e = (*enc)->encode();
    if (!e) return state.SkipWithError(e.error().message.c_str());
    pass += e->gpu_ms;
    readback += e->readback_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["pass_ms"] = pass / n;
  state.counters["readback_10bit_ms"] = readback / n;
  state.counters["render_ms"] = frame->render_ms;
  state.counters["pass_over_render_pct"] = 100.0 * (pass + readback) / n / frame->render_ms;
}
BENCHMARK(BM_EncodePass)
    ->Args({0, 1920, 1080})
    ->Args({1, 1920, 1080})
    ->Args({0, 3840, 2160})
    ->ArgNames({"scene", "w", "h"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5)
    ->UseRealTime();

// The CPU encoder on the same frame, for comparison.
void BM_CpuEncode(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  RenderRequest q;
  q.scene = "material-grid";
  q.width = static_cast<int>(state.range(0));
  q.height = static_cast<int>(state.range(1));
  auto frame = r->render(q);
  if (!frame) return state.SkipWithError(frame.error().message.c_str());
  SceneInput in;
  in.image = &frame->scene_nits;
  in.units = InputUnits::absolute;
  in.illuminance_lux = frame->dominant_illuminance_lux;
  EncodeSettings s;
  s.png_samples = false;
  s.threads = 2;
  auto prepared = prepare_pipeline(in, s);
  if (!prepared) return state.SkipWithError(prepared.error().message.c_str());
  for (auto _ : state) benchmark::DoNotOptimize(encode_prepared(in, *prepared));
}
BENCHMARK(BM_CpuEncode)->Args({1920, 1080})->Unit(benchmark::kMillisecond)->Iterations(5)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();

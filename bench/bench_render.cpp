// Renderer benchmarks (docs/performance.md, docs/rendering.md): frame time of the
// material-grid and hdr scenes at 1920x1080 and 3840x2160, readback cost, the GPU encode
// pass against the render pass, the peak resident memory after a 4K frame, environment
// prefiltering (sky and EXR maps of 2K and 4K) and the 1080p frame under environment light
// against the same frame under a uniform ambient term.
//   LP_NUM_THREADS=2 build/bench/bench_render --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <vector>

#include "encode/io/io.hpp"
#include "shading/environment.hpp"
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

// ---- Environment light ------------------------------------------------------------------

// An equirectangular EXR (a sky-like gradient with a bright soft window), written once;
// `variant` moves the window (a different file of the same size).
std::filesystem::path environment_exr(int width, int variant = 0) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("hdrd_bench_env_" + std::to_string(width) + "_" + std::to_string(variant) + ".exr");
  if (std::filesystem::exists(path)) return path;
  Image img(width, width / 2);
  const Vec3 window = normalize(Vec3{0.6, 0.7, variant ? -0.4 : 0.4});
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Vec3 d = equirect_direction((x + 0.5) / img.width, (y + 0.5) / img.height);
      const double w = std::exp(-40 * (1 - dot(d, window)));
      float* p = img.px(x, y);
      p[0] = float(300 * (1 + d.y) + 20000 * w), p[1] = float(320 * (1 + d.y) + 20000 * w);
      p[2] = float(400 * (1 + d.y) + 20000 * w), p[3] = 1;
    }
  io::ExrWriteOptions o;
  o.half = true;
  (void)io::write_exr(path, img, o);
  return path;
}

EnvironmentSpec bench_environment(int kind, int variant = 0) {
  EnvironmentSpec e;
  if (kind == 0) {
    e.sky = SkyParams{};
    e.sky->sun_elevation_deg = variant ? 30 : 45;
  } else {
    e.file = environment_exr(kind == 1 ? 2048 : 4096, variant);
  }
  return e;
}

// What a new environment costs (RenderResult::environment_ms: load or generate, the CPU
// irradiance, upload, the cube and its GGX prefiltering), alternating two so that every
// frame rebuilds; the 64x64 frame itself is negligible. kind: 0 sky, 1 EXR 2048x1024,
// 2 EXR 4096x2048.
void BM_EnvironmentPrefilter(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  RenderRequest q;
  q.scene = "furnace";
  q.width = 64;
  q.height = 64;
  q.samples = 1;
  const EnvironmentSpec a = bench_environment(static_cast<int>(state.range(0)), 0);
  const EnvironmentSpec b = bench_environment(static_cast<int>(state.range(0)), 1);
  double total = 0;
  int k = 0;
  for (auto _ : state) {
    q.environment = (k++ % 2) ? b : a;
    auto f = r->render(q);
    if (!f) return state.SkipWithError(f.error().message.c_str());
    total += f->environment_ms;
  }
  state.counters["environment_ms"] = total / static_cast<double>(state.iterations());
  // The CPU share alone: building the map and its irradiance (no GL).
  const auto t0 = std::chrono::steady_clock::now();
  auto cpu = build_environment(a);
  if (!cpu) return state.SkipWithError(cpu.error().message.c_str());
  state.counters["cpu_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  state.SetLabel(a.sky ? "Preetham sky 1024x512" : a.file.filename().string());
}
BENCHMARK(BM_EnvironmentPrefilter)
    ->DenseRange(0, 2)
    ->ArgName("kind")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(4)
    ->UseRealTime();

// 1080p frames of material-grid lit by a uniform ambient term and a sun (the peer: the
// shading cost without any environment texture), by its built-in sky and sun, and by a 2K
// EXR map, alternated frame by frame so that all three see the same machine load; the
// counters are the medians of render_ms and their ratios to the peer. Environments are
// built before timing (the renderer keeps one; switching between two rebuilds, so each
// lighting gets its own renderer).
Scene lit_material_grid(int kind) {
  Scene scene = *make_builtin_scene("material-grid");
  if (kind == 0) {
    scene.environment.reset();
    scene.ambient_nits = Vec3{5000, 5000, 5000};
    Light sun;
    sun.direction = normalize(Vec3{-0.4, -0.7, -0.6});
    sun.illuminance_lux = 90000;
    scene.lights.push_back(sun);
  } else if (kind == 2) {
    scene.environment = bench_environment(1);
  }
  return scene;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

void BM_RenderEnvironment(benchmark::State& state) {
  static const char* const kNames[3] = {"ambient_ms", "sky_ms", "exr_ms"};
  std::unique_ptr<Renderer> renderers[3];
  Scene scenes[3];
  RenderSettings s;
  s.width = 1920;
  s.height = 1080;
  s.samples = 4;
  for (int k = 0; k < 3; ++k) {
    auto r = Renderer::create(Backend::automatic);
    if (!r) return state.SkipWithError(r.error().message.c_str());
    renderers[k] = std::move(*r);
    scenes[k] = lit_material_grid(k);
    if (!renderers[k]->render(scenes[k], s).ok()) return state.SkipWithError("render failed");  // warm-up, prefilter
  }
  std::vector<double> ms[3];
  for (auto _ : state)
    for (int k = 0; k < 3; ++k) {
      auto f = renderers[k]->render(scenes[k], s);
      if (!f) return state.SkipWithError(f.error().message.c_str());
      ms[k].push_back(f->render_ms);
    }
  for (int k = 0; k < 3; ++k) state.counters[kNames[k]] = median(ms[k]);
  state.counters["sky_ratio"] = median(ms[1]) / median(ms[0]);
  state.counters["exr_ratio"] = median(ms[2]) / median(ms[0]);
  state.SetLabel("medians of alternated frames; peer: uniform ambient + sun");
}
BENCHMARK(BM_RenderEnvironment)->Unit(benchmark::kMillisecond)->Iterations(5)->UseRealTime();

}  // namespace

// A sequence's frames of a glTF fixture at 1280x720 (4x MSAA, full readback): each frame
// reusing the scene loaded for the frame before (what render() does now for the same
// scene) against loading, validating and uploading it again first (release_scene(): what
// every frame did before scene reuse). Alternated frame by frame, medians.
void BM_SequenceFrame(benchmark::State& state) {
  Renderer* r = renderer();
  if (!r) return state.SkipWithError("no GL context");
  const char* fixtures[] = {"fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb",
                            "fixtures/gltf/NormalTangentTest/NormalTangentTest.glb"};
  const char* dir = std::getenv("HDRD_SHARED_DIR");
  const std::filesystem::path path = std::filesystem::path(dir ? dir : "../shared") / fixtures[state.range(0)];
  if (!std::filesystem::exists(path)) return state.SkipWithError(("missing fixture " + path.string()).c_str());
  RenderRequest q;
  q.scene = path.string();
  q.width = 1280;
  q.height = 720;
  q.samples = 4;
  if (!r->render(q).ok()) return state.SkipWithError("render failed");  // warm-up
  std::vector<double> reuse_ms, reload_ms, load_ms, gpu_reuse_ms, gpu_reload_ms;
  using Clock = std::chrono::steady_clock;
  int frame = 0;
  for (auto _ : state) {
    for (bool reload : {true, false}) {
      if (reload) r->release_scene();
      q.time_s = ++frame / 24.0;
      const auto t0 = Clock::now();
      auto f = r->render(q);
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      if (!f) return state.SkipWithError(f.error().message.c_str());
      (reload ? reload_ms : reuse_ms).push_back(ms);
      if (reload) load_ms.push_back(f->scene_load_ms);
      (reload ? gpu_reload_ms : gpu_reuse_ms).push_back(f->render_ms);
    }
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  state.counters["reload_frame_ms"] = median(reload_ms);
  state.counters["reuse_frame_ms"] = median(reuse_ms);
  state.counters["load_ms"] = median(load_ms);
  state.counters["render_reload_ms"] = median(gpu_reload_ms);  // GPU work incl. the geometry/texture upload
  state.counters["render_reuse_ms"] = median(gpu_reuse_ms);
  state.SetLabel(path.filename().string());
}
BENCHMARK(BM_SequenceFrame)->DenseRange(0, 1)->ArgName("fixture")->Unit(benchmark::kMillisecond)->Iterations(7)->UseRealTime();

BENCHMARK_MAIN();

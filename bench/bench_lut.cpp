// 4K RGBA16F through a 33^3 LUT, tetrahedral: hdrd's Highway kernel (1 and 2 threads)
// beside OpenColorIO 2.1's CPU processor on the same .cube in the same run. Prints the
// speed ratio and the accuracy (max abs difference against OCIO) at the end.
//   bench_lut --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <OpenColorIO/OpenColorIO.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <thread>

#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"

namespace OCIO = OCIO_NAMESPACE;
using namespace hdrd;

namespace {

constexpr int kWidth = 3840, kHeight = 2160, kLutSize = 33;
constexpr std::size_t kPixels = std::size_t(kWidth) * kHeight;

std::uint16_t to_half(float f) {  // inputs here are finite and in [0, 1]
  if (f < 6.103515625e-05f) return std::uint16_t(std::lround(f * 16777216.0f));
  int e;
  const float m = std::frexp(f, &e);  // f = m 2^e, m in [0.5, 1)
  int q = int(std::lround(m * 2048.0f));
  if (q == 2048) q = 1024, ++e;
  return std::uint16_t(((e + 14) << 10) | (q - 1024));
}
float from_half(std::uint16_t h) {
  const int e = (h >> 10) & 0x1F, m = h & 0x3FF;
  return e == 0 ? std::ldexp(float(m), -24) : std::ldexp(float(m | 0x400), e - 25);
}

struct Fixture {
  lut::Lut3D table;
  std::filesystem::path path;
  std::vector<std::uint16_t> input;
  OCIO::ConstCPUProcessorRcPtr ocio_half, ocio_float;
  std::unique_ptr<lut::Applier3D> ours;

  Fixture() {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> noise(-0.05f, 0.05f);
    table = lut::Lut3D::identity(kLutSize);
    for (std::size_t i = 0; i < table.rgb.size(); i += 3) {
      const float r = table.rgb[i], g = table.rgb[i + 1], b = table.rgb[i + 2];
      table.rgb[i] = 0.85f * r + 0.15f * g * b + noise(rng);
      table.rgb[i + 1] = std::sqrt(g) + noise(rng);
      table.rgb[i + 2] = b * b * 0.9f + 0.1f * r + noise(rng);
    }
    path = std::filesystem::temp_directory_path() / "hdrd_bench_lut_33.cube";
    lut::CubeFile cube;
    cube.lut3d = table;
    lut::write_cube(cube, path).value();
    input.resize(kPixels * 4);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (std::size_t i = 0; i < kPixels; ++i) {
      for (int c = 0; c < 3; ++c) input[4 * i + c] = to_half(u(rng));
      input[4 * i + 3] = 0x3C00;
    }
    auto cfg = OCIO::Config::CreateRaw();
    auto ft = OCIO::FileTransform::Create();
    ft->setSrc(path.c_str());
    ft->setInterpolation(OCIO::INTERP_TETRAHEDRAL);
    auto proc = cfg->getProcessor(ft);
    ocio_half = proc->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F16, OCIO::BIT_DEPTH_F16, OCIO::OPTIMIZATION_DEFAULT);
    ocio_float = proc->getDefaultCPUProcessor();
    ours = std::make_unique<lut::Applier3D>(table, lut::Interpolation::tetrahedral);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

// OCIO's apply is single-threaded per call; two threads each take half the rows.
void ocio_apply_half(const std::uint16_t* in, std::uint16_t* out, int threads) {
  auto& f = fixture();
  const auto run = [&](int y0, int y1) {
    OCIO::PackedImageDesc src(const_cast<std::uint16_t*>(in) + std::size_t(y0) * kWidth * 4, kWidth, y1 - y0, 4,
                              OCIO::BIT_DEPTH_F16, 2, 8, std::ptrdiff_t(kWidth) * 8);
    OCIO::PackedImageDesc dst(out + std::size_t(y0) * kWidth * 4, kWidth, y1 - y0, 4, OCIO::BIT_DEPTH_F16, 2, 8,
                              std::ptrdiff_t(kWidth) * 8);
    f.ocio_half->apply(src, dst);
  };
  if (threads <= 1) return run(0, kHeight);
  std::thread t(run, 0, kHeight / 2);
  run(kHeight / 2, kHeight);
  t.join();
}

void BM_Ocio_Half(benchmark::State& state) {
  auto& f = fixture();
  std::vector<std::uint16_t> out(f.input.size());
  for (auto _ : state) {
    ocio_apply_half(f.input.data(), out.data(), int(state.range(0)));
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(kPixels));
}

void BM_Hdrd_Half(benchmark::State& state) {
  auto& f = fixture();
  std::vector<std::uint16_t> out(f.input.size());
  for (auto _ : state) {
    f.ours->apply_half(f.input.data(), out.data(), kPixels, int(state.range(0)));
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(kPixels));
}

void BM_Hdrd_Float(benchmark::State& state) {
  auto& f = fixture();
  std::vector<float> px(f.input.size());
  for (auto _ : state) {
    state.PauseTiming();
    for (std::size_t i = 0; i < px.size(); ++i) px[i] = from_half(f.input[i]);
    state.ResumeTiming();
    f.ours->apply(px.data(), kPixels, int(state.range(0)));
    benchmark::DoNotOptimize(px.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(kPixels));
}

// The whole display-placement grade as the encoder runs it per row: PQ shaper on display
// nits, the table, PQ decode (one thread; the pipeline spreads rows over threads).
void BM_Grade_Display(benchmark::State& state) {
  auto& f = fixture();
  grade::GradeSettings gs;
  gs.lut_path = f.path.string();
  const auto g = grade::load_grade(gs, 1000, nullptr).value();
  std::vector<float> px(f.input.size());
  for (std::size_t i = 0; i < px.size(); ++i) px[i] = from_half(f.input[i]) * 1000.0f;
  for (auto _ : state) {  // regrading the graded frame: still display nits, same work
    for (int y = 0; y < kHeight; ++y) g->apply(px.data() + std::size_t(y) * kWidth * 4, kWidth);
    benchmark::DoNotOptimize(px.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(kPixels));
}

// Parsing a 65^3 .cube (274,625 lines).
void BM_ParseCube65(benchmark::State& state) {
  lut::CubeFile cube;
  cube.lut3d = lut::Lut3D::identity(65);
  const std::string text = lut::format_cube(cube).value();
  for (auto _ : state) benchmark::DoNotOptimize(lut::parse_cube(text).ok());
  state.SetBytesProcessed(state.iterations() * std::int64_t(text.size()));
}

BENCHMARK(BM_Grade_Display)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ParseCube65)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ocio_Half)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Hdrd_Half)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Hdrd_Float)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Keeps each run's real time per iteration so main() can print the ratios.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) {
      const std::string key = r.run_name.function_name + "/" + r.run_name.args;
      if (r.run_type == Run::RT_Iteration && !ms.count(key + "#median")) ms[key] = r.GetAdjustedRealTime();
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median")
        ms[key] = r.GetAdjustedRealTime(), ms[key + "#median"] = 1;  // repetitions: the median wins
    }
    ConsoleReporter::ReportRuns(runs);
  }
  std::map<std::string, double> ms;
};

// Accuracy: the same half input through both, half outputs compared as floats; and the
// float path against OCIO's float processor.
void report_accuracy() {
  auto& f = fixture();
  std::vector<std::uint16_t> a(f.input.size()), b(f.input.size());
  ocio_apply_half(f.input.data(), a.data(), 2);
  f.ours->apply_half(f.input.data(), b.data(), kPixels, 2);
  double half_diff = 0;
  for (std::size_t i = 0; i < kPixels; ++i)
    for (int c = 0; c < 3; ++c)
      half_diff = std::max(half_diff, double(std::fabs(from_half(a[4 * i + c]) - from_half(b[4 * i + c]))));
  std::size_t differ = 0;
  int max_ulp = 0;
  for (std::size_t i = 0; i < kPixels; ++i)
    for (int c = 0; c < 3; ++c)
      if (a[4 * i + c] != b[4 * i + c]) ++differ, max_ulp = std::max(max_ulp, std::abs(int(a[4 * i + c]) - int(b[4 * i + c])));
  double float_diff = 0;
  for (std::size_t i = 0; i < kPixels; i += 97) {  // a 1 % sample through OCIO's float path
    float px[4] = {from_half(f.input[4 * i]), from_half(f.input[4 * i + 1]), from_half(f.input[4 * i + 2]), 1};
    float ours[4] = {px[0], px[1], px[2], 1};
    f.ocio_float->applyRGBA(px);
    f.ours->apply(ours, 1, 1);
    for (int c = 0; c < 3; ++c) float_diff = std::max(float_diff, double(std::fabs(px[c] - ours[c])));
  }
  std::printf("accuracy: max |hdrd - OCIO| half out %.3g (%zu of %zu values differ, by at most %d half ULP), "
              "float out %.3g\n", half_diff, differ, kPixels * 3, max_ulp, float_diff);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  fixture();
  std::printf("hdrd SIMD target: %s, LUT %d^3 tetrahedral, %dx%d RGBA16F\n", lut::simd_target_name().c_str(), kLutSize,
              kWidth, kHeight);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  const auto& ms = reporter.ms;
  for (const char* t : {"1", "2"}) {
    const std::string o = std::string("BM_Ocio_Half/") + t, h = std::string("BM_Hdrd_Half/") + t;
    if (ms.count(o) && ms.count(h))
      std::printf("ratio %s thread(s): OCIO %.1f ms / hdrd %.1f ms = %.1fx faster\n", t, ms.at(o), ms.at(h),
                  ms.at(o) / ms.at(h));
  }
  report_accuracy();
  benchmark::Shutdown();
  std::filesystem::remove(fixture().path);
  return 0;
}

// Encode benchmark (issue: encode core): 3840x2160 RGBA16F -> HDR10 / SDR / scRGB with
// exposure + the mode's default tone curve + matrix + transfer + pack, at 1 and 2 threads,
// beside (same run) the OpenColorIO 2.1 CPU processor doing matrix + transfer, and a
// memory-bandwidth floor that reads and writes the same bytes. Counters report the code
// error against the double-precision reference path.
#include <benchmark/benchmark.h>

#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <thread>

#if HDRD_HAVE_ZIMG
#include <zimg.h>
#endif

#include "bench/encode_inputs.hpp"
#include "encode/pipeline.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/colour/transfer.hpp"

namespace OCIO = OCIO_NAMESPACE;
using namespace hdrd;

namespace {

using bench::frame_half;
using bench::kH;
using bench::kW;
using bench::settings_for;

void run_hdrd(benchmark::State& st, Mode mode, bool ui) {
  SceneInput in;
  in.half = &frame_half();
  auto s = settings_for(mode, static_cast<int>(st.range(0)));
  if (ui) {
    bench::add_ui_overlay(s);
  }
  // Steady state of a real-time loop: settings prepared per frame (metering included),
  // the scan-out buffer reused.
  EncodedFrame frame;
  for (auto _ : st) {
    auto p = prepare_pipeline(in, s);
    if (!p) st.SkipWithError(p.error().message.c_str());
    auto ok = encode_prepared_into(in, *p, frame);
    if (!ok) st.SkipWithError(ok.error().message.c_str());
    benchmark::DoNotOptimize(frame.data.data());
  }

}

void BM_hdrd_hdr10(benchmark::State& st) { run_hdrd(st, Mode::hdr10, false); }
void BM_hdrd_hdr10_ui(benchmark::State& st) { run_hdrd(st, Mode::hdr10, true); }
void BM_hdrd_sdr(benchmark::State& st) { run_hdrd(st, Mode::sdr, false); }
void BM_hdrd_scrgb(benchmark::State& st) { run_hdrd(st, Mode::scrgb, false); }

// Memory floor: read 8 B/px (half RGBA), write out_bytes per pixel, nothing else, on
// `threads` threads (contiguous halves of the frame; one core alone cannot use all of the
// machine's bandwidth, so each hdrd variant is held against the floor at its own thread count).
void floor_rows(const std::uint64_t* src, std::uint8_t* out, int out_bytes, std::size_t begin, std::size_t end) {
  if (out_bytes == 4) {
    auto* dst = reinterpret_cast<std::uint32_t*>(out);
    for (std::size_t i = begin; i < end; ++i) dst[i] = static_cast<std::uint32_t>(src[i] ^ (src[i] >> 32));
  } else {
    auto* dst = reinterpret_cast<std::uint64_t*>(out);
    for (std::size_t i = begin; i < end; ++i) dst[i] = src[i] ^ 0x1;
  }
}

void BM_floor(benchmark::State& st) {
  const auto& in = frame_half();
  const int out_bytes = static_cast<int>(st.range(0));
  const int threads = static_cast<int>(st.range(1));
  std::vector<std::uint8_t> out(static_cast<std::size_t>(kW) * kH * out_bytes);
  const auto* src = reinterpret_cast<const std::uint64_t*>(in.rgba.data());
  const std::size_t n = in.pixel_count();
  for (auto _ : st) {
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t)
      pool.emplace_back(floor_rows, src, out.data(), out_bytes, n * t / threads, n * (t + 1) / threads);
    floor_rows(src, out.data(), out_bytes, 0, n / threads);
    for (auto& th : pool) th.join();
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}

// OpenColorIO 2.1 CPU processor on the same half input: matrix 709 -> 2020 and ST 2084
// (HDR10), 709 -> XYZ -> sRGB display (SDR), a scale matrix (scRGB). OCIO's 1.0 = 100 cd/m2.
OCIO::ConstCPUProcessorRcPtr ocio_processor(Mode mode) {
  auto cfg = OCIO::Config::CreateRaw();
  auto group = OCIO::GroupTransform::Create();
  auto mat = [](const color::Mat3& m, double scale) {
    auto t = OCIO::MatrixTransform::Create();
    double m44[16] = {0};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m44[i * 4 + j] = m.m[i][j] * scale;
    m44[15] = 1;
    t->setMatrix(m44);
    return t;
  };
  if (mode == Mode::hdr10) {
    group->appendTransform(mat(color::rgb_to_rgb(color::kRec709, color::kRec2020), 2.03));
    auto b = OCIO::BuiltinTransform::Create();
    b->setStyle("CURVE - LINEAR_to_ST-2084");
    group->appendTransform(b);
  } else if (mode == Mode::sdr) {
    group->appendTransform(mat(color::rgb_to_xyz(color::kRec709), 1.0));
    auto b = OCIO::BuiltinTransform::Create();
    b->setStyle("DISPLAY - CIE-XYZ-D65_to_sRGB");
    group->appendTransform(b);
  } else {
    group->appendTransform(mat(color::Mat3::identity(), 203.0 / 80.0));
  }
  return cfg->getProcessor(group)->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F16, OCIO::BIT_DEPTH_F16,
                                                            OCIO::OPTIMIZATION_DEFAULT);
}

void run_ocio(benchmark::State& st, Mode mode) {
  auto proc = ocio_processor(mode);
  ImageHalf work = frame_half();
  for (auto _ : st) {
    st.PauseTiming();
    std::memcpy(work.rgba.data(), frame_half().rgba.data(), work.rgba.size() * 2);
    st.ResumeTiming();
    OCIO::PackedImageDesc desc(work.rgba.data(), kW, kH, OCIO::CHANNEL_ORDERING_RGBA, OCIO::BIT_DEPTH_F16,
                               2, 8, static_cast<std::ptrdiff_t>(kW) * 8);
    proc->apply(desc);
    benchmark::DoNotOptimize(work.rgba.data());
  }
}
void BM_ocio_hdr10(benchmark::State& st) { run_ocio(st, Mode::hdr10); }
void BM_ocio_sdr(benchmark::State& st) { run_ocio(st, Mode::sdr); }
void BM_ocio_scrgb(benchmark::State& st) { run_ocio(st, Mode::scrgb); }

#if HDRD_HAVE_ZIMG
// zimg 3.0 (the library behind ffmpeg's zscale) doing only what zscale would for this frame:
// Rec.709 -> Rec.2020 primaries + ST 2084 (HDR10, 10-bit full range in 16-bit words) or the
// sRGB curve (SDR, 8-bit), no tone curve, no exposure, no pack. zimg works on planes, so its
// input is the same frame as planar half floats (6 B/px in, 6 or 3 B/px out), which is what
// zscale is fed. Threads as zscale's slice threading: one graph per horizontal band.
// args: threads, approximate gamma (zscale's `approximate_gamma`).
constexpr std::size_t kPlane = static_cast<std::size_t>(kW) * kH;

const std::vector<std::uint16_t>& planar_half() {
  static const std::vector<std::uint16_t> planes = [] {
    const auto& img = frame_half();
    std::vector<std::uint16_t> p(3 * kPlane);
    for (std::size_t i = 0; i < kPlane; ++i)
      for (int c = 0; c < 3; ++c) p[c * kPlane + i] = img.rgba[i * 4 + c];
    return p;
  }();
  return planes;
}

void run_zimg(benchmark::State& st, Mode mode) {
  const int threads = static_cast<int>(st.range(0));
  const bool approximate = st.range(1) != 0;
  const bool hdr = mode == Mode::hdr10;
  const int out_bytes = hdr ? 2 : 1;
  // kW * 2 and kW are multiples of 64: planes stay 64-byte aligned from an aligned base.
  auto* in = static_cast<std::uint16_t*>(std::aligned_alloc(64, 3 * kPlane * 2));
  auto* out = static_cast<std::uint8_t*>(std::aligned_alloc(64, 3 * kPlane * out_bytes));
  std::memcpy(in, planar_half().data(), 3 * kPlane * 2);

  const int band = (kH + threads - 1) / threads;
  struct Slice {
    zimg_filter_graph* graph = nullptr;
    void* tmp = nullptr;
    int y0 = 0, rows = 0;
  };
  std::vector<Slice> slices;
  for (int y0 = 0; y0 < kH; y0 += band) {
    Slice sl;
    sl.y0 = y0;
    sl.rows = std::min(band, kH - y0);
    zimg_image_format src, dst;
    zimg_image_format_default(&src, ZIMG_API_VERSION);
    zimg_image_format_default(&dst, ZIMG_API_VERSION);
    src.width = dst.width = kW;
    src.height = dst.height = static_cast<unsigned>(sl.rows);
    src.pixel_type = ZIMG_PIXEL_HALF;
    src.color_family = dst.color_family = ZIMG_COLOR_RGB;
    src.matrix_coefficients = dst.matrix_coefficients = ZIMG_MATRIX_RGB;
    src.transfer_characteristics = ZIMG_TRANSFER_LINEAR;
    src.color_primaries = ZIMG_PRIMARIES_709;
    src.pixel_range = dst.pixel_range = ZIMG_RANGE_FULL;
    dst.pixel_type = hdr ? ZIMG_PIXEL_WORD : ZIMG_PIXEL_BYTE;
    dst.depth = hdr ? 10 : 8;
    dst.transfer_characteristics = hdr ? ZIMG_TRANSFER_ST2084 : ZIMG_TRANSFER_IEC_61966_2_1;
    dst.color_primaries = hdr ? ZIMG_PRIMARIES_2020 : ZIMG_PRIMARIES_709;
    zimg_graph_builder_params params;
    zimg_graph_builder_params_default(&params, ZIMG_API_VERSION);
    params.cpu_type = ZIMG_CPU_AUTO_64B;
    params.nominal_peak_luminance = 203.0;  // 1.0 = paper white, as hdrd's relative input
    params.allow_approximate_gamma = approximate ? 1 : 0;
    sl.graph = zimg_filter_graph_build(&src, &dst, &params);
    if (!sl.graph) {
      char msg[256];
      zimg_get_last_error(msg, sizeof msg);
      st.SkipWithError(msg);
      return;
    }
    std::size_t tmp_size = 0;
    zimg_filter_graph_get_tmp_size(sl.graph, &tmp_size);
    sl.tmp = std::aligned_alloc(64, (tmp_size + 63) / 64 * 64 + 64);
    slices.push_back(sl);
  }
  auto process = [&](const Slice& sl) {
    zimg_image_buffer_const src{};
    zimg_image_buffer dst{};
    src.version = dst.version = ZIMG_API_VERSION;
    for (int c = 0; c < 3; ++c) {
      src.plane[c].data = in + c * kPlane + static_cast<std::size_t>(sl.y0) * kW;
      src.plane[c].stride = kW * 2;
      src.plane[c].mask = ZIMG_BUFFER_MAX;
      dst.plane[c].data = out + (c * kPlane + static_cast<std::size_t>(sl.y0) * kW) * out_bytes;
      dst.plane[c].stride = kW * out_bytes;
      dst.plane[c].mask = ZIMG_BUFFER_MAX;
    }
    zimg_filter_graph_process(sl.graph, &src, &dst, sl.tmp, nullptr, nullptr, nullptr, nullptr);
  };
  for (auto _ : st) {
    std::vector<std::thread> workers;
    for (std::size_t i = 1; i < slices.size(); ++i) workers.emplace_back(process, std::cref(slices[i]));
    process(slices[0]);
    for (auto& w : workers) w.join();
    benchmark::DoNotOptimize(out);
    benchmark::ClobberMemory();
  }
  // Its codes against the double-precision reference of the same transform (every 5th pixel).
  const auto m = color::rgb_to_rgb(color::kRec709, hdr ? color::kRec2020 : color::kRec709);
  long worst = 0, off = 0, total = 0;
  for (std::size_t i = 0; i < kPlane; i += 5) {
    auto in_c = [&](int c) { return static_cast<double>(detail::half_to_float(planar_half()[c * kPlane + i])); };
    const color::Vec3 w = m * color::Vec3{in_c(0), in_c(1), in_c(2)};
    for (int c = 0; c < 3; ++c) {
      const double x = std::max(0.0, w[c]);
      const double e = hdr ? transfer::pq_inverse_eotf(x * 203.0) : transfer::srgb_inverse_eotf(std::min(x, 1.0));
      const long want = std::lround(std::clamp(e, 0.0, 1.0) * (hdr ? 1023 : 255));
      const long got = hdr ? reinterpret_cast<const std::uint16_t*>(out)[c * kPlane + i] : out[c * kPlane + i];
      worst = std::max(worst, std::labs(got - want));
      off += got != want;
      ++total;
    }
  }
  st.counters["max_code_error"] = static_cast<double>(worst);
  st.counters["pct_off"] = 100.0 * off / std::max(1L, total);
  for (auto& sl : slices) {
    zimg_filter_graph_free(sl.graph);
    std::free(sl.tmp);
  }
  std::free(in);
  std::free(out);
}
void BM_zimg_hdr10(benchmark::State& st) { run_zimg(st, Mode::hdr10); }
void BM_zimg_sdr(benchmark::State& st) { run_zimg(st, Mode::sdr); }
#endif

// Accuracy against the double-precision reference, on every 5th pixel of the frame.
void accuracy(benchmark::State& st, Mode mode) {
  SceneInput in;
  in.half = &frame_half();
  auto s = settings_for(mode, 2);
  auto p = prepare_pipeline(in, s).value();
  auto f = encode_prepared(in, p).value();
  const auto sig = detail::build_signal_stage(s.target);
  long worst = 0, off = 0, total = 0;
  for (auto _ : st) {
    for (std::size_t i = 0; i < in.half->pixel_count(); i += 5) {
      const auto* h = &in.half->rgba[i * 4];
      const color::Vec3 v{detail::half_to_float(h[0]), detail::half_to_float(h[1]), detail::half_to_float(h[2])};
      const color::Vec3 e = reference_signal(s.target, reference_display_nits(p, v));
      for (int c = 0; c < 3; ++c) {
        long want, got;
        if (mode == Mode::scrgb) {
          // Compare in half ULPs of the FP16 output.
          want = detail::float_to_half(static_cast<float>(e[c]));
          got = reinterpret_cast<const std::uint16_t*>(f.data.data())[i * 4 + c];
        } else if (f.drm_fourcc == kDrmFormatXrgb8888) {
          want = static_cast<long>(std::clamp(e[c], 0.0, 1.0) * sig.code_scale + 0.5);
          got = f.data[i * 4 + 2 - c];
        } else {
          want = static_cast<long>(std::clamp(e[c], 0.0, 1.0) * sig.code_scale + 0.5);
          std::uint32_t w;
          std::memcpy(&w, &f.data[i * 4], 4);
          got = (w >> (10 * c)) & 1023;
        }
        worst = std::max(worst, std::labs(got - want));
        off += got != want;
        ++total;
      }
    }
  }
  st.counters["max_code_error"] = static_cast<double>(worst);
  st.counters["pct_off_by_one"] = 100.0 * off / std::max(1L, total);
}
void BM_accuracy_hdr10(benchmark::State& st) { accuracy(st, Mode::hdr10); }
void BM_accuracy_sdr(benchmark::State& st) { accuracy(st, Mode::sdr); }
void BM_accuracy_scrgb(benchmark::State& st) { accuracy(st, Mode::scrgb); }

}  // namespace

BENCHMARK(BM_floor)->ArgsProduct({{4, 8}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_hdrd_hdr10)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_hdrd_hdr10_ui)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_hdrd_sdr)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_hdrd_scrgb)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ocio_hdr10)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ocio_sdr)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ocio_scrgb)->Unit(benchmark::kMillisecond)->UseRealTime();
#if HDRD_HAVE_ZIMG
BENCHMARK(BM_zimg_hdr10)->ArgsProduct({{1, 2}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_zimg_sdr)->ArgsProduct({{1, 2}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();
#endif
BENCHMARK(BM_accuracy_hdr10)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_accuracy_sdr)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_accuracy_scrgb)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();

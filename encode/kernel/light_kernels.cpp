// Highway dynamic dispatch: this file is compiled once per SIMD target.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "encode/kernel/light_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include "encode/kernel/half-inl.h"
#include "encode/kernel/light_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace hdrd::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Samples per chunk: the SIMD step fills a chunk, the scalar one empties it (the codes'
// counting) or fills it (the halves' gather). A multiple of every target's lane count.
constexpr int kChunk = 512;

// Four interleaved histograms: neighbouring pixels often share a code, and one table's
// increments would wait on each other (a store-to-load chain per pixel).
constexpr int kWays = 4;

void MaxCodeHistogramImpl(const std::uint8_t* data, int width, int height, std::size_t stride_bytes,
                          std::array<std::uint64_t, 1024>& histogram, std::array<std::uint32_t, 3>& max_code) {
  const hn::ScalableTag<std::uint32_t> du;
  const int N = static_cast<int>(hn::Lanes(du));
  const auto mask = hn::Set(du, 1023u);
  std::vector<std::uint32_t> ways(static_cast<std::size_t>(kWays) * 1024, 0);
  std::uint32_t* w0 = ways.data();
  auto vmax_r = hn::Zero(du), vmax_g = hn::Zero(du), vmax_b = hn::Zero(du);
  std::uint32_t tail_max[3] = {0, 0, 0};
  alignas(64) std::uint32_t codes[kChunk];
  for (int y = 0; y < height; ++y) {
    const auto* row = reinterpret_cast<const std::uint32_t*>(data + static_cast<std::size_t>(y) * stride_bytes);
    const int n_full = width - width % N;
    for (int x0 = 0; x0 < n_full; x0 += kChunk) {
      const int n = std::min(kChunk, n_full - x0);
      for (int i = 0; i < n; i += N) {
        const auto w = hn::LoadU(du, row + x0 + i);
        const auto r = hn::And(w, mask), g = hn::And(hn::ShiftRight<10>(w), mask), b = hn::And(hn::ShiftRight<20>(w), mask);
        vmax_r = hn::Max(vmax_r, r), vmax_g = hn::Max(vmax_g, g), vmax_b = hn::Max(vmax_b, b);
        hn::Store(hn::Max(hn::Max(r, g), b), du, codes + i);
      }
      int i = 0;
      for (; i + kWays <= n; i += kWays)
        for (int k = 0; k < kWays; ++k) ++w0[k * 1024 + codes[i + k]];
      for (; i < n; ++i) ++w0[codes[i]];
    }
    for (int x = n_full; x < width; ++x) {
      std::uint32_t w;
      std::memcpy(&w, row + x, 4);
      const std::uint32_t c[3] = {w & 1023, (w >> 10) & 1023, (w >> 20) & 1023};
      for (int k = 0; k < 3; ++k) tail_max[k] = std::max(tail_max[k], c[k]);
      ++w0[std::max({c[0], c[1], c[2]})];
    }
  }
  for (int c = 0; c < 1024; ++c)
    for (int k = 0; k < kWays; ++k) histogram[static_cast<std::size_t>(c)] += w0[k * 1024 + c];
  const std::uint32_t lanes_max[3] = {hn::GetLane(hn::MaxOfLanes(du, vmax_r)), hn::GetLane(hn::MaxOfLanes(du, vmax_g)),
                                      hn::GetLane(hn::MaxOfLanes(du, vmax_b))};
  for (int k = 0; k < 3; ++k)
    max_code[static_cast<std::size_t>(k)] = std::max({max_code[static_cast<std::size_t>(k)], lanes_max[k], tail_max[k]});
}

void StridedHalfRgbImpl(const std::uint16_t* rgba, std::size_t step, std::size_t count, float* r, float* g, float* b) {
  const hn::ScalableTag<float> df;
  const hn::Rebind<std::uint16_t, decltype(df)> du16;
  const std::size_t N = hn::Lanes(df);
  alignas(64) std::uint16_t planes[3][kChunk];
  alignas(64) float floats[3][kChunk];
  float* const out[3] = {r, g, b};
  for (std::size_t k0 = 0; k0 < count; k0 += kChunk) {
    const std::size_t n = std::min<std::size_t>(kChunk, count - k0);
    // The gather: one 8-byte pixel per sample, split into planes the vectors read, the
    // last vector's unused lanes zero.
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint16_t* p = rgba + (k0 + i) * step * 4;
      planes[0][i] = p[0], planes[1][i] = p[1], planes[2][i] = p[2];
    }
    const std::size_t padded = (n + N - 1) / N * N;  // <= kChunk, a multiple of N
    for (auto& plane : planes) std::fill(plane + n, plane + padded, std::uint16_t{0});
    for (int c = 0; c < 3; ++c) {
      for (std::size_t i = 0; i < padded; i += N) hn::Store(half_to_float(df, hn::Load(du16, planes[c] + i)), df, floats[c] + i);
      std::memcpy(out[c] + k0, floats[c], n * sizeof(float));
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace hdrd::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace hdrd::kernels {
HWY_EXPORT(MaxCodeHistogramImpl);
HWY_EXPORT(StridedHalfRgbImpl);
void max_code_histogram(const std::uint8_t* data, int width, int height, std::size_t stride_bytes,
                        std::array<std::uint64_t, 1024>& histogram, std::array<std::uint32_t, 3>& max_code) {
  HWY_DYNAMIC_DISPATCH(MaxCodeHistogramImpl)(data, width, height, stride_bytes, histogram, max_code);
}
void strided_half_rgb(const std::uint16_t* rgba, std::size_t step, std::size_t count, float* r, float* g, float* b) {
  HWY_DYNAMIC_DISPATCH(StridedHalfRgbImpl)(rgba, step, count, r, g, b);
}
}  // namespace hdrd::kernels
#endif

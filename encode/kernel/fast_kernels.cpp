#include "encode/kernel/fast_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "encode/kernel/pipeline_internal.hpp"

namespace hdrd::kernels {

namespace {
inline float sanitize(float v) {
  // NaN -> 0 (the comparison is false for NaN), magnitudes clamped to 1e30.
  return v == v ? std::clamp(v, -1e30f, 1e30f) : 0.0f;
}
inline void to_working(float r, float g, float b, const float* m, float* o) {
  r = sanitize(r), g = sanitize(g), b = sanitize(b);
  o[0] = m[0] * r + m[1] * g + m[2] * b;
  o[1] = m[3] * r + m[4] * g + m[5] * b;
  o[2] = m[6] * r + m[7] * g + m[8] * b;
  o[3] = 1.0f;
}
}  // namespace

void half_rows_to_working(const std::uint16_t* in, int n, const float* m, float* out) {
  for (int i = 0; i < n; ++i)
    to_working(detail::half_to_float(in[i * 4]), detail::half_to_float(in[i * 4 + 1]),
               detail::half_to_float(in[i * 4 + 2]), m, out + i * 4);
}

void float_rows_to_working(const float* in, int n, const float* m, float* out) {
  for (int i = 0; i < n; ++i) to_working(in[i * 4], in[i * 4 + 1], in[i * 4 + 2], m, out + i * 4);
}

void tone_clip(float* row, int n, float paper_white, float peak) {
  for (int i = 0; i < n * 4; i += 4)
    for (int c = 0; c < 3; ++c) row[i + c] = std::min(std::max(row[i + c], 0.0f) * paper_white, peak);
}

void tone_ratio(float* row, int n, const FloatBitsLut& lut, bool luminance, const float* m) {
  for (int i = 0; i < n * 4; i += 4) {
    const float r = std::max(row[i], 0.0f), g = std::max(row[i + 1], 0.0f), b = std::max(row[i + 2], 0.0f);
    float k = luminance ? kernel::rec2020_luminance(r, g, b) : std::max({r, g, b});
    if (!luminance && m)
      k = std::max({k, m[0] * r + m[1] * g + m[2] * b, m[3] * r + m[4] * g + m[5] * b, m[6] * r + m[7] * g + m[8] * b});
    float ratio = 0;
    if (k > 0) ratio = k < lut.hi() ? lut(k) : lut(lut.hi()) * (lut.hi() / k);
    row[i] = r * ratio, row[i + 1] = g * ratio, row[i + 2] = b * ratio;
  }
}

void encode_pq_row(const float* row, int n, const FloatBitsLut& pq, float code_scale, float code_offset,
                   const float* code_to_nits, std::uint32_t* out, std::uint16_t* signal16, bool narrow,
                   double& max_nits, double& sum_nits) {
  for (int x = 0; x < n; ++x) {
    int code[3];
    for (int c = 0; c < 3; ++c) {
      const float e = std::clamp(pq(row[x * 4 + c]), 0.0f, 1.0f);
      code[c] = std::min(static_cast<int>(e * code_scale + code_offset + 0.5f), 1023);
      if (signal16)
        signal16[x * 3 + c] = static_cast<std::uint16_t>(
            narrow ? static_cast<int>(code[c] * kernel::kCode10To16 + 0.5f) : static_cast<int>(e * kernel::kMax16 + 0.5f));
    }
    out[x] = static_cast<std::uint32_t>(code[0]) | (static_cast<std::uint32_t>(code[1]) << 10) |
             (static_cast<std::uint32_t>(code[2]) << 20) | (3u << 30);
    const float mx = code_to_nits[std::max({code[0], code[1], code[2]})];
    max_nits = std::max<double>(max_nits, mx);
    sum_nits += mx;
  }
}

}  // namespace hdrd::kernels

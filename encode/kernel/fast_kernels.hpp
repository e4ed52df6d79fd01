// Hot row kernels of the encode fast path. Each takes a row of n RGBA pixels; the
// implementations (fast_kernels.cpp) dispatch at run time to the best SIMD target
// Highway finds (SSE4, AVX2, AVX-512, ...); the build needs no particular ISA.
#pragma once

#include <cstdint>

#include "encode/kernel/float_lut.hpp"

namespace hdrd::kernels {

// Half RGBA -> sanitised (NaN -> 0, |v| <= 1e30) working-space RGBA via a 3x3 matrix
// (row-major, exposure folded in). Alpha is set to 1.
void half_rows_to_working(const std::uint16_t* in, int n, const float* m, float* out);
void float_rows_to_working(const float* in, int n, const float* m, float* out);

// Negatives to 0, then nits = min(x * paper_white, peak) per channel.
void tone_clip(float* row, int n, float paper_white, float peak);
// Negatives to 0, then rgb *= lut(k) with k = max(r, g, b) or Rec.2020 luminance.
// With `container` (row-major 3x3, or null) the max also covers the output container's
// channels, so no output channel passes the peak.
void tone_ratio(float* row, int n, const FloatBitsLut& lut, bool luminance, const float* container);

// Fused HDR10 tail for rows already in container nits: PQ via the signal LUT, full or
// narrow quantisation, XBGR2101010 packing, 16-bit PNG samples (may be null) and the
// MaxCLL accumulation from decoded codes. Returns nothing; adds to max/sum.
void encode_pq_row(const float* row, int n, const FloatBitsLut& pq, float code_scale, float code_offset,
                   const float* code_to_nits, std::uint32_t* out, std::uint16_t* signal16, bool narrow,
                   double& max_nits, double& sum_nits);

}  // namespace hdrd::kernels

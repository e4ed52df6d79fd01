// SIMD kernels of the light statistics: the maxRGB code histogram that sequence metadata
// (MaxCLL, MaxFALL, HDR10+ percentiles, Dolby Vision L1) is measured from
// (content_light.cpp), and the strided half reads of the luminance samples that exposure
// metering and the temporal decisions rest on (pipeline.cpp scene_luminance_nits).
// Dispatch at run time to the best SIMD target (Highway). Both give exactly what their
// scalar definitions (in the comments) give: counts and half -> float are exact.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace hdrd::kernels {

// For the rows of a frame of XBGR2101010 words (R in bits 0-9, G 10-19, B 20-29):
//   ++histogram[max(R, G, B)] for every pixel, max_code[c] = max(max_code[c], channel c)
// (both added to what they hold).
void max_code_histogram(const std::uint8_t* data, int width, int height, std::size_t stride_bytes,
                        std::array<std::uint64_t, 1024>& histogram, std::array<std::uint32_t, 3>& max_code);

// r[k], g[k], b[k] = the R, G, B halves of pixel `k * step` of half RGBA pixels, as floats,
// for k in [0, count).
void strided_half_rgb(const std::uint16_t* rgba, std::size_t step, std::size_t count, float* r, float* g, float* b);

}  // namespace hdrd::kernels

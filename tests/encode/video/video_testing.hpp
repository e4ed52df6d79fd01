// Frames for the video tests: EncodedFrames filled with chosen codes, and the BT.2020 /
// BT.709 Y'CbCr equations evaluated here, independently of encode/video/ycbcr.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <array>
#include <cstring>
#include <random>
#include <vector>

#include "encode/display_target.hpp"
#include "encode/frame.hpp"

namespace hdrd::video::testing {

// A frame whose pixel (x, y) has the codes code(x, y) = {R, G, B} in the target's range.
template <class CodeOf>
EncodedFrame frame_of_codes(Mode mode, Range range, int bits, int w, int h, CodeOf code) {
  EncodedFrame f;
  f.target = default_target(mode);
  f.target.range = range;
  f.target.bits = bits;
  f.width = w;
  f.height = h;
  f.drm_fourcc = bits == 8 ? kDrmFormatXrgb8888 : kDrmFormatXbgr2101010;
  f.stride_bytes = static_cast<std::size_t>(w) * 4 + 16;  // padded rows
  f.data.assign(f.stride_bytes * static_cast<std::size_t>(h), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto c = code(x, y);
      std::uint32_t word = bits == 8 ? (static_cast<std::uint32_t>(c[2]) | (c[1] << 8) | (c[0] << 16) | 0xFF000000u)
                                     : (static_cast<std::uint32_t>(c[0]) | (c[1] << 10) | (c[2] << 20) | (3u << 30));
      std::memcpy(f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4, &word, 4);
    }
  f.mastering = f.target.mastering();
  f.content_light = measure_content_light(f);
  return f;
}

// Random codes over the whole legal range of the frame's range.
inline EncodedFrame random_frame(Mode mode, Range range, int bits, int w, int h, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const int q = 1 << (bits - 8);
  const int lo = range == Range::narrow ? 16 * q : 0, hi = range == Range::narrow ? 235 * q : (1 << bits) - 1;
  std::uniform_int_distribution<int> d(lo, hi);
  return frame_of_codes(mode, range, bits, w, h, [&](int, int) { return std::array<int, 3>{d(rng), d(rng), d(rng)}; });
}

struct Codes {
  std::uint32_t r, g, b;
};
inline Codes codes_at(const EncodedFrame& f, int x, int y) {
  std::uint32_t w;
  std::memcpy(&w, f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4, 4);
  if (f.drm_fourcc == kDrmFormatXrgb8888) return {(w >> 16) & 255, (w >> 8) & 255, w & 255};
  return {w & 1023, (w >> 10) & 1023, (w >> 20) & 1023};
}

// E' of a code (BT.2100 Table 9, inverted).
inline double signal_of(std::uint32_t code, int bits, Range range) {
  const double q = std::ldexp(1.0, bits - 8);
  return range == Range::narrow ? (code / q - 16.0) / 219.0 : code / (std::ldexp(1.0, bits) - 1);
}

// The equations of BT.2020 §4 / BT.709 §3 (non-constant luminance), with their published
// constants, and the quantisation of BT.2100 Table 9. Unrounded code values.
struct YcbcrExact {
  double y, cb, cr;
};
inline YcbcrExact ycbcr_exact(double r, double g, double b, bool rec2020, int bits, Range out) {
  const double kr = rec2020 ? 0.2627 : 0.2126, kb = rec2020 ? 0.0593 : 0.0722, kg = 1 - kr - kb;
  const double y = kr * r + kg * g + kb * b;
  const double cb = (b - y) / (rec2020 ? 1.8814 : 1.8556);  // 2 (1 - Kb), as published
  const double cr = (r - y) / (rec2020 ? 1.4746 : 1.5748);  // 2 (1 - Kr)
  const double q = std::ldexp(1.0, bits - 8), full = std::ldexp(1.0, bits) - 1;
  if (out == Range::narrow) return {(219 * y + 16) * q, (224 * cb + 128) * q, (224 * cr + 128) * q};
  return {full * y, full * cb + std::ldexp(1.0, bits - 1), full * cr + std::ldexp(1.0, bits - 1)};
}

}  // namespace hdrd::video::testing

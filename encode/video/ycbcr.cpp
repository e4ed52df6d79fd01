#include "encode/video/ycbcr.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "encode/io/internal.hpp"

namespace hdrd::video {

Result<YcbcrFormat> ycbcr_format_for(const EncodedFrame& frame, Range range) {
  YcbcrFormat f;
  f.range = range;
  switch (frame.target.mode) {
    case Mode::hdr10:
    case Mode::hlg: f.luma = color::kRec2020Luma; break;
    case Mode::sdr:
    case Mode::sdr_bt1886: f.luma = color::kRec709Luma; break;
    case Mode::scrgb:
      return make_error("video.mode", "scrgb is linear FP16 and has no Y'CbCr video form; use hdr10, hlg or sdr",
                        "display.mode");
  }
  if (frame.drm_fourcc == kDrmFormatXbgr2101010) {
    f.bits = 10;
  } else if (frame.drm_fourcc == kDrmFormatXrgb8888) {
    f.bits = 8;
  } else {
    return make_error("video.format", fmt::format("cannot make video of DRM format {}", fourcc_name(frame.drm_fourcc)),
                      "display.bits");
  }
  return f;
}

namespace {

// Every step is linear in the codes c of the frame's own range, E' = a c + b:
//   Y code  = y_scale * (Kr cR + Kg cG + Kb cB) + y_offset
//   Cb code = cb_scale * (F_B - (Kr F_R + Kg F_G + Kb F_B)) + c_offset, F = 8 x the filtered code
// with the rounding's +0.5 folded into the offsets (the kernels truncate, then clamp,
// which equals clamping floor() for every value). Single precision: within 3e-4 of a code
// of the double-precision equations, so a code differs from them only where they sit
// within that of a rounding tie.
struct Coeffs {
  float kr, kg, kb;
  float y_scale, y_offset;
  float cb_scale, cr_scale, c_offset;
  int max_code;
};

Coeffs coeffs_for(const YcbcrFormat& f, Range input_range) {
  const int n = f.bits;
  const double q = std::ldexp(1.0, n - 8);
  // Decoding the input codes (BT.2100 Table 9 inverted).
  const double a = input_range == Range::narrow ? 1.0 / (219.0 * q) : 1.0 / (std::ldexp(1.0, n) - 1);
  const double b = input_range == Range::narrow ? -16.0 / 219.0 : 0.0;
  // Quantising Y'CbCr.
  const double sy = f.range == Range::narrow ? 219.0 * q : std::ldexp(1.0, n) - 1;
  const double oy = f.range == Range::narrow ? 16.0 * q : 0.0;
  const double sc = f.range == Range::narrow ? 224.0 * q : std::ldexp(1.0, n) - 1;
  const double oc = f.range == Range::narrow ? 128.0 * q : std::ldexp(1.0, n - 1);
  const double kr = f.luma.x, kg = f.luma.y, kb = f.luma.z;
  Coeffs c;
  c.kr = static_cast<float>(kr), c.kg = static_cast<float>(kg), c.kb = static_cast<float>(kb);
  c.y_scale = static_cast<float>(sy * a);
  c.y_offset = static_cast<float>(sy * b * (kr + kg + kb) + oy + 0.5);
  c.cb_scale = static_cast<float>(sc * a / (8.0 * 2.0 * (1.0 - kb)));
  c.cr_scale = static_cast<float>(sc * a / (8.0 * 2.0 * (1.0 - kr)));
  c.c_offset = static_cast<float>(oc + 0.5);
  c.max_code = (1 << n) - 1;
  return c;
}

// The row kernels are plain loops over contiguous arrays that GCC vectorises; each is
// compiled for AVX2 and for the baseline, chosen at load time (target_clones), as
// Highway's dynamic dispatch does for encode/kernel.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define HDRD_ROW_KERNEL __attribute__((target_clones("avx2", "default")))
#else
#define HDRD_ROW_KERNEL
#endif

inline float channel(std::uint32_t w, bool ten_bit, int c) {
  // XBGR2101010: R in bits 0-9; XRGB8888: bytes B, G, R, X.
  if (ten_bit) return static_cast<float>((w >> (10 * c)) & 1023);
  return static_cast<float>((w >> (16 - 8 * c)) & 255);
}

template <class T>
inline T quantise(float v, int max_code) {
  return static_cast<T>(std::clamp(static_cast<int>(v), 0, max_code));
}

// Luma of one packed row; the row's R, G, B added into the column sums s (row 2j + 2j+1).
template <class T, bool kTen>
inline void luma_and_sums(const Coeffs& c, const std::uint32_t* __restrict src, int width, T* __restrict out,
                          float* __restrict sr, float* __restrict sg, float* __restrict sb, bool first_row) {
  for (int x = 0; x < width; ++x) {
    const std::uint32_t w = src[x];
    const float r = channel(w, kTen, 0), g = channel(w, kTen, 1), b = channel(w, kTen, 2);
    out[x] = quantise<T>(c.y_scale * (c.kr * r + c.kg * g + c.kb * b) + c.y_offset, c.max_code);
    sr[x] = first_row ? r : sr[x] + r;
    sg[x] = first_row ? g : sg[x] + g;
    sb[x] = first_row ? b : sb[x] + b;
  }
}

// [1 2 1] across columns (edges replicated) into h, then chroma at the even columns.
template <class T>
inline void chroma_row(const Coeffs& c, const float* __restrict sr, const float* __restrict sg,
                       const float* __restrict sb, int width, float* __restrict hr, float* __restrict hg,
                       float* __restrict hb, T* __restrict cb, T* __restrict cr) {
  for (int x = 1; x < width - 1; ++x) {
    hr[x] = sr[x - 1] + 2 * sr[x] + sr[x + 1];
    hg[x] = sg[x - 1] + 2 * sg[x] + sg[x + 1];
    hb[x] = sb[x - 1] + 2 * sb[x] + sb[x + 1];
  }
  hr[0] = 3 * sr[0] + sr[1], hg[0] = 3 * sg[0] + sg[1], hb[0] = 3 * sb[0] + sb[1];
  for (int i = 0; i < width / 2; ++i) {
    const float fr = hr[2 * i], fg = hg[2 * i], fb = hb[2 * i];
    const float fy = c.kr * fr + c.kg * fg + c.kb * fb;
    cb[i] = quantise<T>(c.cb_scale * (fb - fy) + c.c_offset, c.max_code);
    cr[i] = quantise<T>(c.cr_scale * (fr - fy) + c.c_offset, c.max_code);
  }
}

HDRD_ROW_KERNEL void luma_row_10(const Coeffs& c, const std::uint32_t* src, int w, std::uint16_t* out, float* sr, float* sg,
                                 float* sb, bool first) {
  luma_and_sums<std::uint16_t, true>(c, src, w, out, sr, sg, sb, first);
}
HDRD_ROW_KERNEL void luma_row_8(const Coeffs& c, const std::uint32_t* src, int w, std::uint8_t* out, float* sr, float* sg,
                                float* sb, bool first) {
  luma_and_sums<std::uint8_t, false>(c, src, w, out, sr, sg, sb, first);
}
HDRD_ROW_KERNEL void chroma_row_10(const Coeffs& c, const float* s, int w, float* h, std::uint16_t* cb, std::uint16_t* cr) {
  chroma_row<std::uint16_t>(c, s, s + w, s + 2 * w, w, h, h + w, h + 2 * w, cb, cr);
}
HDRD_ROW_KERNEL void chroma_row_8(const Coeffs& c, const float* s, int w, float* h, std::uint8_t* cb, std::uint8_t* cr) {
  chroma_row<std::uint8_t>(c, s, s + w, s + 2 * w, w, h, h + w, h + 2 * w, cb, cr);
}

template <class T>
T* row_of(const Plane& p, int y) {
  return reinterpret_cast<T*>(p.data + static_cast<std::ptrdiff_t>(y) * p.stride_bytes);
}

template <class T>
void convert(const EncodedFrame& f, const Coeffs& c, const Planes420& out) {
  const int w = f.width;
  std::vector<float> buf(static_cast<std::size_t>(w) * 6);  // column sums R, G, B; filtered R, G, B
  std::vector<std::uint32_t> words(static_cast<std::size_t>(w));
  float *sums = buf.data(), *filtered = buf.data() + 3 * w;
  for (int y = 0; y < f.height; ++y) {
    // memcpy: the rows need no 4-byte alignment in the frame's buffer.
    std::memcpy(words.data(), f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes, static_cast<std::size_t>(w) * 4);
    if constexpr (sizeof(T) == 2)
      luma_row_10(c, words.data(), w, row_of<T>(out.y, y), sums, sums + w, sums + 2 * w, y % 2 == 0);
    else
      luma_row_8(c, words.data(), w, row_of<T>(out.y, y), sums, sums + w, sums + 2 * w, y % 2 == 0);
    if (y % 2 == 0) continue;
    if constexpr (sizeof(T) == 2)
      chroma_row_10(c, sums, w, filtered, row_of<T>(out.cb, y / 2), row_of<T>(out.cr, y / 2));
    else
      chroma_row_8(c, sums, w, filtered, row_of<T>(out.cb, y / 2), row_of<T>(out.cr, y / 2));
  }
}

}  // namespace

Result<void> rgb_to_ycbcr420(const EncodedFrame& frame, const YcbcrFormat& format, const Planes420& out) {
  if (auto ok = io::detail::check_frame(frame); !ok) return ok.error();
  if (frame.width % 2 || frame.height % 2)
    return make_error("video.size",
                      fmt::format("4:2:0 video needs an even width and height, not {}x{}", frame.width, frame.height),
                      "size");
  const int frame_bits = frame.drm_fourcc == kDrmFormatXbgr2101010 ? 10 : 8;
  if (format.bits != frame_bits)
    return make_error("video.format", fmt::format("Y'CbCr depth {} does not match the frame's {}-bit codes", format.bits,
                                                  frame_bits), "display.bits");
  if (!out.y.data || !out.cb.data || !out.cr.data) return make_error("video.planes", "no output planes given");
  const Coeffs c = coeffs_for(format, frame.target.range);
  if (format.bits == 10)
    convert<std::uint16_t>(frame, c, out);
  else
    convert<std::uint8_t>(frame, c, out);
  return {};
}

}  // namespace hdrd::video

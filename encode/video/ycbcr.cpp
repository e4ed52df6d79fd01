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
// with the rounding's +0.5 folded into the offsets (the kernel truncates, then clamps,
// which equals clamping floor() for every value).
struct Coeffs {
  double kr, kg, kb;
  double y_scale, y_offset;
  double cb_scale, cr_scale, c_offset;
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
  Coeffs c;
  c.kr = f.luma.x, c.kg = f.luma.y, c.kb = f.luma.z;
  c.y_scale = sy * a;
  c.y_offset = sy * b * (c.kr + c.kg + c.kb) + oy + 0.5;
  c.cb_scale = sc * a / (8.0 * 2.0 * (1.0 - c.kb));
  c.cr_scale = sc * a / (8.0 * 2.0 * (1.0 - c.kr));
  c.c_offset = oc + 0.5;
  c.max_code = (1 << n) - 1;
  return c;
}

inline int quantise(double v, int max_code) { return std::clamp(static_cast<int>(v), 0, max_code); }

// One row of packed codes -> three planar int rows.
void unpack_row(const std::uint8_t* src, int width, bool ten_bit, int* r, int* g, int* b) {
  for (int x = 0; x < width; ++x) {
    std::uint32_t w;
    std::memcpy(&w, src + static_cast<std::size_t>(x) * 4, 4);
    if (ten_bit) {  // XBGR2101010: R in bits 0-9
      r[x] = static_cast<int>(w & 1023), g[x] = static_cast<int>((w >> 10) & 1023), b[x] = static_cast<int>((w >> 20) & 1023);
    } else {  // XRGB8888: bytes B, G, R, X
      b[x] = static_cast<int>(w & 255), g[x] = static_cast<int>((w >> 8) & 255), r[x] = static_cast<int>((w >> 16) & 255);
    }
  }
}

template <class T>
void luma_row(const Coeffs& c, const int* r, const int* g, const int* b, int width, T* out) {
  for (int x = 0; x < width; ++x)
    out[x] = static_cast<T>(quantise(c.y_scale * (c.kr * r[x] + c.kg * g[x] + c.kb * b[x]) + c.y_offset, c.max_code));
}

// Chroma of one row pair from the column sums s = row 2j + row 2j+1.
template <class T>
void chroma_row(const Coeffs& c, const int* sr, const int* sg, const int* sb, int width, T* cb, T* cr) {
  for (int i = 0; i < width / 2; ++i) {
    const int x = 2 * i, l = x > 0 ? x - 1 : 0;
    const double fr = sr[l] + 2 * sr[x] + sr[x + 1];
    const double fg = sg[l] + 2 * sg[x] + sg[x + 1];
    const double fb = sb[l] + 2 * sb[x] + sb[x + 1];
    const double fy = c.kr * fr + c.kg * fg + c.kb * fb;
    cb[i] = static_cast<T>(quantise(c.cb_scale * (fb - fy) + c.c_offset, c.max_code));
    cr[i] = static_cast<T>(quantise(c.cr_scale * (fr - fy) + c.c_offset, c.max_code));
  }
}

template <class T>
T* row_of(const Plane& p, int y) {
  return reinterpret_cast<T*>(p.data + static_cast<std::ptrdiff_t>(y) * p.stride_bytes);
}

template <class T>
void convert(const EncodedFrame& f, const Coeffs& c, const Planes420& out) {
  const int w = f.width;
  std::vector<int> buf(static_cast<std::size_t>(w) * 9);
  int *r0 = buf.data(), *g0 = r0 + w, *b0 = g0 + w, *r1 = b0 + w, *g1 = r1 + w, *b1 = g1 + w;
  int *sr = b1 + w, *sg = sr + w, *sb = sg + w;
  const bool ten = f.drm_fourcc == kDrmFormatXbgr2101010;
  for (int j = 0; j < f.height / 2; ++j) {
    const std::uint8_t* top = f.data.data() + static_cast<std::size_t>(2 * j) * f.stride_bytes;
    unpack_row(top, w, ten, r0, g0, b0);
    unpack_row(top + f.stride_bytes, w, ten, r1, g1, b1);
    luma_row(c, r0, g0, b0, w, row_of<T>(out.y, 2 * j));
    luma_row(c, r1, g1, b1, w, row_of<T>(out.y, 2 * j + 1));
    for (int x = 0; x < w; ++x) sr[x] = r0[x] + r1[x], sg[x] = g0[x] + g1[x], sb[x] = b0[x] + b1[x];
    chroma_row(c, sr, sg, sb, w, row_of<T>(out.cb, j), row_of<T>(out.cr, j));
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

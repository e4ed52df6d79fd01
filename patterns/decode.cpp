#include "patterns/decode.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "encode/colour/transfer.hpp"

namespace hdrd::patterns {

float half_bits_to_float(std::uint16_t h) {
  const int sign = (h >> 15) & 1, exponent = (h >> 10) & 31, mantissa = h & 1023;
  double v;
  if (exponent == 0) v = std::ldexp(mantissa, -24);
  else if (exponent == 31) v = mantissa ? NAN : INFINITY;
  else v = std::ldexp(mantissa + 1024, exponent - 25);
  return static_cast<float>(sign ? -v : v);
}

PixelSignal read_pixel(const EncodedFrame& f, int x, int y) {
  PixelSignal p;
  const std::uint8_t* row = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
  if (f.drm_fourcc == kDrmFormatAbgr16161616f) {
    std::uint16_t h[3];
    std::memcpy(h, row + static_cast<std::size_t>(x) * 8, 6);
    for (int c = 0; c < 3; ++c) p.scrgb[c] = half_bits_to_float(h[c]);
  } else if (f.drm_fourcc == kDrmFormatXrgb8888) {
    const std::uint8_t* px = row + static_cast<std::size_t>(x) * 4;  // bytes B, G, R, X
    p.code[0] = px[2], p.code[1] = px[1], p.code[2] = px[0];
  } else {
    std::uint32_t w;
    std::memcpy(&w, row + static_cast<std::size_t>(x) * 4, 4);
    p.code[0] = static_cast<int>(w & 1023), p.code[1] = static_cast<int>((w >> 10) & 1023);
    p.code[2] = static_cast<int>((w >> 20) & 1023);
  }
  return p;
}

double code_to_signal(const DisplayTarget& t, int code) {
  return t.range == Range::narrow ? transfer::dequantize_narrow(code, t.bits) : transfer::dequantize_full(code, t.bits);
}

color::Vec3 decode_codes(const DisplayTarget& t, const int code[3]) {
  const color::Vec3 e{code_to_signal(t, code[0]), code_to_signal(t, code[1]), code_to_signal(t, code[2])};
  switch (t.mode) {
    case Mode::hdr10:
      return {transfer::pq_eotf(std::max(e.x, 0.0)), transfer::pq_eotf(std::max(e.y, 0.0)),
              transfer::pq_eotf(std::max(e.z, 0.0))};
    case Mode::hlg:
      return transfer::hlg_eotf({std::max(e.x, 0.0), std::max(e.y, 0.0), std::max(e.z, 0.0)}, t.peak_nits,
                                t.black_nits);
    case Mode::sdr: {
      auto f = [&](double v) {
        v = std::clamp(v, 0.0, 1.0);
        return t.peak_nits * (t.sdr_curve == SdrCurve::srgb ? transfer::srgb_eotf(v) : transfer::gamma22_eotf(v));
      };
      return {f(e.x), f(e.y), f(e.z)};
    }
    case Mode::sdr_bt1886: {
      const auto b = transfer::Bt1886::from_levels(t.peak_nits, t.black_nits);
      return {b.eotf(e.x), b.eotf(e.y), b.eotf(e.z)};
    }
    case Mode::scrgb:
      break;
  }
  return {};
}

color::Vec3 decode_pixel(const EncodedFrame& f, int x, int y) {
  const PixelSignal p = read_pixel(f, x, y);
  if (f.target.mode == Mode::scrgb)
    return color::Vec3{p.scrgb[0], p.scrgb[1], p.scrgb[2]} * transfer::kScrgbUnitNits;
  return decode_codes(f.target, p.code);
}

}  // namespace hdrd::patterns

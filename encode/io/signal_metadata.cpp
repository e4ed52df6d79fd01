#include "encode/io/signal_metadata.hpp"

#include <algorithm>
#include <cmath>

namespace hdrd::io {

// H.273 code points. SDR: 13 = IEC 61966-2-1 sRGB; 4 = BT.470 System M, "assumed display
// gamma 2.2"; 1 = BT.709, whose reference display EOTF is BT.1886 (H.273 Table 3 note).
H273 h273_for(const DisplayTarget& t) {
  switch (t.mode) {
    case Mode::hdr10: return {9, 16};
    case Mode::hlg: return {9, 18};
    case Mode::sdr: return {1, static_cast<std::uint8_t>(t.sdr_curve == SdrCurve::srgb ? 13 : 4)};
    case Mode::sdr_bt1886: return {1, 1};
    case Mode::scrgb: break;
  }
  return {1, 8};  // scRGB: BT.709 primaries, linear (H.273 transfer 8) as the closest statement
}

std::uint32_t to_units(double value, double unit, double max, bool round_up) {
  if (!(value > 0)) return 0;  // also NaN
  const double units = value / unit;
  // The small slack keeps exact values such as 123.45 cd/m2 from rounding to the next unit.
  const double r = round_up ? std::ceil(units - 1e-6) : std::round(units);
  return static_cast<std::uint32_t>(std::min(r, max));
}

St2086Codes st2086_codes(const MasteringDisplay& m) {
  auto xy = [](color::Chromaticity c) {
    return std::array<std::uint16_t, 2>{static_cast<std::uint16_t>(to_units(c.x, 0.00002, 50000, false)),
                                        static_cast<std::uint16_t>(to_units(c.y, 0.00002, 50000, false))};
  };
  St2086Codes s;
  s.red = xy(m.primaries.red), s.green = xy(m.primaries.green), s.blue = xy(m.primaries.blue);
  s.white = xy(m.primaries.white);
  s.max_luminance = to_units(m.max_nits, 0.0001, 4294967295.0, false);
  s.min_luminance = to_units(m.min_nits, 0.0001, 4294967295.0, false);
  return s;
}

Cta861Light cta861_light(const ContentLightLevel& light, const MasteringDisplay& m) {
  const auto peak = to_units(m.max_nits, 1, 65535, true);
  auto carried = [&](double nits) {
    const auto u = to_units(nits, 1, 65535, true);
    return static_cast<std::uint16_t>(u != 0 ? u : peak);
  };
  Cta861Light c{carried(light.max_cll_nits), carried(light.max_fall_nits)};
  c.max_fall = std::min(c.max_fall, c.max_cll);  // a frame average cannot exceed the brightest pixel
  return c;
}

}  // namespace hdrd::io

// What the still writers (PNG, AVIF, JPEG XL, JPEG) say about a frame's signal: H.273 code
// points, ST 2086 and CTA-861.3 values in container units, and the frame's samples.
#include <algorithm>
#include <cmath>

#include "encode/io/internal.hpp"

namespace hdrd::io::detail {

// H.273 code points. SDR: 13 = IEC 61966-2-1 sRGB; 4 = BT.470 System M, "assumed display
// gamma 2.2"; 1 = BT.709, whose reference display EOTF is BT.1886 (H.273 Table 3 note).
Cicp cicp_for(const DisplayTarget& t) {
  Cicp c;
  switch (t.mode) {
    case Mode::hdr10: c.primaries = 9; c.transfer = 16; break;
    case Mode::hlg: c.primaries = 9; c.transfer = 18; break;
    case Mode::sdr: c.transfer = t.sdr_curve == SdrCurve::srgb ? 13 : 4; break;
    case Mode::sdr_bt1886: c.transfer = 1; break;
    case Mode::scrgb: break;  // rejected by every caller before this
  }
  c.full_range = t.range == Range::full;
  return c;
}

std::uint8_t ycbcr_matrix(const DisplayTarget& t) { return cicp_for(t).primaries == 9 ? 9 : 1; }

namespace {
std::uint32_t to_units(double value, double unit, double max, bool round_up) {
  if (!(value > 0)) return 0;  // also NaN
  const double units = value / unit;
  // The small slack keeps exact values such as 123.45 cd/m2 from rounding up to the next unit.
  const double r = round_up ? std::ceil(units - 1e-6) : std::round(units);
  return static_cast<std::uint32_t>(std::min(r, max));
}
std::array<std::uint16_t, 2> xy_units(color::Chromaticity c) {
  return {static_cast<std::uint16_t>(to_units(c.x, 0.00002, 65535, false)),
          static_cast<std::uint16_t>(to_units(c.y, 0.00002, 65535, false))};
}
}  // namespace

St2086Units st2086_units(const MasteringDisplay& m) {
  St2086Units u;
  u.red = xy_units(m.primaries.red);
  u.green = xy_units(m.primaries.green);
  u.blue = xy_units(m.primaries.blue);
  u.white = xy_units(m.primaries.white);
  u.max_luminance = to_units(m.max_nits, 0.0001, 4294967295.0, false);
  u.min_luminance = to_units(m.min_nits, 0.0001, 4294967295.0, false);
  return u;
}

std::uint32_t carried_light(double nits, double unit_nits, double max_units, const MasteringDisplay& m) {
  const auto units = to_units(nits, unit_nits, max_units, true);
  return units != 0 ? units : to_units(m.max_nits, unit_nits, max_units, true);
}

}  // namespace hdrd::io::detail

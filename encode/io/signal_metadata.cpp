#include "encode/io/signal_metadata.hpp"

#include <algorithm>
#include <cmath>

namespace hdrd::io {

std::uint8_t ycbcr_matrix(const DisplayTarget& t) {
  return h273(t).primaries == 9 ? kH273MatrixBt2020Ncl : kH273MatrixBt709;
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
  const CarriedLightLevel c = carried_light_level(light, m);
  return {c.max_cll_nits, c.max_fall_nits};
}

}  // namespace hdrd::io

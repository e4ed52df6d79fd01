#include "encode/frame.hpp"

#include <algorithm>
#include <cmath>

namespace hdrd {

namespace {
// Whole cd/m2, rounded up; the slack keeps 1000 computed as 1000.0000000002 at 1000.
double ceil_nits(double nits) { return nits > 0 && std::isfinite(nits) ? std::ceil(nits - 1e-6) : 0.0; }
}  // namespace

CarriedLightLevel carried_light_level(const ContentLightLevel& l, const MasteringDisplay& m) {
  constexpr double kMax = 65535;
  // The mastering maximum in whole cd/m2 rounded down: a carried MaxCLL never exceeds the
  // mastering display's maximum (426.856 cd/m2 carried 428 before the peak's code was capped,
  // and rounding a measured 426.2 up would still carry 427).
  const double peak = std::clamp(std::floor(m.max_nits + 1e-6), 1.0, kMax);
  double cll = std::min({ceil_nits(l.max_cll_nits), peak, kMax}), fall = std::min(ceil_nits(l.max_fall_nits), kMax);
  if (cll == 0) cll = peak;
  if (fall == 0) fall = peak;
  return {static_cast<std::uint16_t>(cll), static_cast<std::uint16_t>(std::min(fall, cll))};
}

}  // namespace hdrd

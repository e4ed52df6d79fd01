#include "encode/colour/sdr_content.hpp"

#include <algorithm>
#include <cmath>

#include "encode/colour/transfer.hpp"

namespace hdrd {

std::string_view to_string(SdrEotf e) {
  switch (e) {
    case SdrEotf::srgb: return "srgb";
    case SdrEotf::gamma22: return "gamma22";
    case SdrEotf::bt1886: return "bt1886";
  }
  return "?";
}

std::optional<SdrEotf> parse_sdr_eotf(std::string_view s) {
  for (SdrEotf e : {SdrEotf::srgb, SdrEotf::gamma22, SdrEotf::bt1886})
    if (to_string(e) == s) return e;
  if (s == "gamma2.2") return SdrEotf::gamma22;
  return std::nullopt;
}

namespace {
// BT.1886 with Lb = 0: a = Lw, b = 0, so L / Lw = V^2.4.
constexpr double kBt1886Gamma = 2.4;
}  // namespace

double sdr_eotf(SdrEotf e, double v) {
  v = std::clamp(v, 0.0, 1.0);
  switch (e) {
    case SdrEotf::srgb: return transfer::srgb_eotf(v);
    case SdrEotf::gamma22: return transfer::gamma22_eotf(v);
    case SdrEotf::bt1886: return std::pow(v, kBt1886Gamma);
  }
  return v;
}

double sdr_inverse_eotf(SdrEotf e, double l) {
  l = std::clamp(l, 0.0, 1.0);
  switch (e) {
    case SdrEotf::srgb: return transfer::srgb_inverse_eotf(l);
    case SdrEotf::gamma22: return transfer::gamma22_inverse_eotf(l);
    case SdrEotf::bt1886: return std::pow(l, 1.0 / kBt1886Gamma);
  }
  return l;
}

}  // namespace hdrd

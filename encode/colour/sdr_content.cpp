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

std::string_view to_string(InverseTonemap m) {
  switch (m) {
    case InverseTonemap::linear: return "linear";
    case InverseTonemap::bt2446c: return "bt2446c";
  }
  return "?";
}

std::optional<InverseTonemap> parse_inverse_tonemap(std::string_view s) {
  for (InverseTonemap m : {InverseTonemap::linear, InverseTonemap::bt2446c})
    if (to_string(m) == s) return m;
  if (s == "bt2446a-inverse") return InverseTonemap::bt2446c;
  return std::nullopt;
}

double sdr_light_to_nits(InverseTonemap m, double light, double white, double peak) {
  if (m == InverseTonemap::linear) return light * white;
  const double y = std::clamp(light, 0.0, 1.0);
  const double y_ip = kBt2446cKnee, k3 = kBt2446cK3;
  const double nits_ip = y_ip * white;
  if (!(peak > nits_ip)) return std::min(y * white, peak);
  if (y <= y_ip) return y * white;
  // (exp((1 - k4) / k2) + k3) * nits_ip = peak, with k4 = y_ip - k2 ln(1 - k3).
  const double k2 = (1 - y_ip) / std::log((peak / nits_ip - k3) / (1 - k3));
  const double k4 = y_ip - k2 * std::log(1 - k3);
  if (y >= 1) return peak;
  return std::min((std::exp((y - k4) / k2) + k3) * nits_ip, peak);
}

}  // namespace hdrd

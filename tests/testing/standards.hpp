// The standards' equations written out for tests, independently of hdrd's encode module:
// an oracle a test computes its expected values with (never hdrd's functions). Each cites
// the document it is written from.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace hdrd::testing::standard {

// SMPTE ST 2084: nits -> E' and E' -> nits.
inline double pq_inverse_eotf(double nits) {
  const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
               c3 = 2392.0 / 4096 * 32;
  const double y = std::pow(std::max(nits, 0.0) / 10000, m1);
  return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
}
inline double pq_eotf(double e) {
  const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
               c3 = 2392.0 / 4096 * 32;
  const double p = std::pow(std::clamp(e, 0.0, 1.0), 1 / m2);
  return 10000 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1 / m1);
}

// ITU-R BT.2100-2 Table 5, HLG: OETF, its inverse, the system gamma of note 5f (the
// extended range formula outside 400 .. 2000 cd/m2), the black lift beta and the EOTF
// F_D = Lw Y_S^(gamma - 1) E, E = OETF^-1[max(0, (1 - beta) E' + beta)].
inline double hlg_oetf(double e) {
  const double a = 0.17883277, b = 1 - 4 * a, c = 0.55991073;  // as Table 5 publishes them
  return e <= 1.0 / 12 ? std::sqrt(3 * std::max(e, 0.0)) : a * std::log(12 * e - b) + c;
}
inline double hlg_inverse_oetf(double s) {
  const double a = 0.17883277, b = 1 - 4 * a, c = 0.55991073;
  return s <= 0.5 ? s * s / 3 : (std::exp((s - c) / a) + b) / 12;
}
inline double hlg_gamma(double lw) {
  return lw >= 400 && lw <= 2000 ? 1.2 + 0.42 * std::log10(lw / 1000) : 1.2 * std::pow(1.111, std::log2(lw / 1000));
}
inline double hlg_beta(double lw, double lb) { return std::sqrt(3 * std::pow(lb / lw, 1 / hlg_gamma(lw))); }
inline std::array<double, 3> hlg_eotf(std::array<double, 3> signal, double lw, double lb) {
  const double g = hlg_gamma(lw), beta = hlg_beta(lw, lb);
  std::array<double, 3> e{};
  for (int c = 0; c < 3; ++c) e[c] = hlg_inverse_oetf(std::max(0.0, (1 - beta) * signal[c] + beta));
  const double ys = 0.2627 * e[0] + 0.6780 * e[1] + 0.0593 * e[2];
  const double k = ys > 0 ? lw * std::pow(ys, g - 1) : 0.0;
  return {k * e[0], k * e[1], k * e[2]};
}
// The signal of grey display light (F_D = Lw E^gamma inverted, then the lift).
inline double hlg_grey_signal(double nits, double lw, double lb) {
  const double beta = hlg_beta(lw, lb);
  const double e = std::pow(std::clamp(nits / lw, 0.0, 1.0), 1 / hlg_gamma(lw));
  return std::clamp((hlg_oetf(e) - beta) / (1 - beta), 0.0, 1.0);
}

// ITU-R BT.2390-10 §5.4 EETF: E1 from the source range [lb, lw], the Hermite spline above
// KS = 1.5 maxLum - 0.5, E3 = E2 + b (1 - E2)^4 with b = minLum, E4 back to light.
struct Bt2390Report {
  double lb, lw, lmin, lmax;  // source black and peak; display black and peak (cd/m2)
  double range() const { return pq_inverse_eotf(lw) - pq_inverse_eotf(lb); }
  double e1(double nits) const { return std::clamp((pq_inverse_eotf(nits) - pq_inverse_eotf(lb)) / range(), 0.0, 1.0); }
  double e2(double e1v) const {
    const double max_lum = (pq_inverse_eotf(lmax) - pq_inverse_eotf(lb)) / range();
    const double ks = 1.5 * max_lum - 0.5;
    if (!(e1v >= ks && ks < 1)) return e1v;
    const double t = (e1v - ks) / (1 - ks), t2 = t * t, t3 = t2 * t;
    return (2 * t3 - 3 * t2 + 1) * ks + (t3 - 2 * t2 + t) * (1 - ks) + (-2 * t3 + 3 * t2) * max_lum;
  }
  double e3(double e2v) const {
    const double min_lum = (pq_inverse_eotf(lmin) - pq_inverse_eotf(lb)) / range();
    return e2v + min_lum * std::pow(1 - e2v, 4);
  }
  double to_nits(double e) const { return pq_eotf(e * range() + pq_inverse_eotf(lb)); }
  // The whole EETF with E3, and without it (the roll-off alone).
  double operator()(double nits) const { return to_nits(e3(e2(e1(nits)))); }
  double rolloff(double nits) const { return to_nits(e2(e1(nits))); }
  // E3 applied to light that came out of the roll-off (per channel after a ratio).
  double lift(double nits) const { return to_nits(e3(e1(nits))); }
};

}  // namespace hdrd::testing::standard

// Internal: the built-in tone curves' math, shared by the registry (tonemap.cpp).
// Each function follows its source; `W` is the display maximum in paper-white units.
#pragma once

#include <cmath>
#include <vector>

namespace hdrd::tonemap::detail {

// Many SDR-practice curves are defined as g: [0, inf) -> [0, 1]. Made peak-aware as
// y = W * g(x / W): for SDR (W = 1) this is the classic curve; for HDR it stretches the
// curve to the display maximum. (REFERENCE.md §1.3: peak/paper_white is the display maximum.)

// Uncharted 2 filmic (Hable 2010), A..F as published.
struct Hable {
  double a = 0.15, b = 0.50, c = 0.10, d = 0.20, e = 0.02, f = 0.30;
  double raw(double x) const {
    return (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f;
  }
};

// Hable 2017 "Filmic Tonemapping with Piecewise Power Curves": user params -> direct params
// -> three power segments (toe, linear, shoulder), normalised to reach 1 at the white point.
class HablePiecewise {
 public:
  HablePiecewise(double toe_strength, double toe_length, double shoulder_strength,
                 double shoulder_length, double shoulder_angle, double gamma);
  double eval(double x) const;  // x in scene units; 1 at white point
  double white_point() const { return w_; }
  std::vector<double> kinks() const { return {w_ * x0_, w_ * x1_, w_}; }  // segment joins, white point

 private:
  struct Segment {
    double offset_x = 0, offset_y = 0, scale_x = 1, scale_y = 1, ln_a = 0, b = 1;
    double eval(double x) const {
      const double x0 = (x - offset_x) * scale_x;
      const double y0 = x0 > 0 ? std::exp(ln_a + b * std::log(x0)) : 0.0;
      return y0 * scale_y + offset_y;
    }
  };
  double w_ = 1, inv_w_ = 1, x0_ = 0, x1_ = 0;
  Segment toe_, mid_, shoulder_;
};

// Lottes 2016 "Advanced Techniques and Optimization of HDR Color Pipelines" (GDC):
// y = x^a / (x^(a d) b + c) with b, c solved so hdr_max -> 1 and mid_in -> mid_out.
struct Lottes {
  double a, d, b, c;
  Lottes(double contrast, double shoulder, double hdr_max, double mid_in, double mid_out);
  double eval(double x) const { return x <= 0 ? 0.0 : std::pow(x, a) / (std::pow(x, a * d) * b + c); }
};

// Day 2012 (Insomniac Games), "An efficient and user-friendly tone mapping operator":
// toe and shoulder rational segments meeting at the crossover point, 1 at the white point.
struct Day {
  double black, white, crossover, toe, shoulder, k;
  Day(double black_point, double white_point, double crossover_point, double toe_strength,
      double shoulder_strength);
  double eval(double x) const;
  std::vector<double> kinks() const { return {black, crossover, white}; }
};

// Exponential shoulder in the PQ domain: identity up to a knee, then
// e_out = knee + (peak - knee)(1 - exp(-(e - knee)/(peak - knee))): C1 at the knee,
// asymptotic to the display peak. The knee sits halfway (in PQ) between paper white and
// peak, so reference white is kept whenever peak > paper white; for SDR (peak = paper
// white) it starts 10 % below the peak's PQ value.
struct PqShoulder {
  double e_knee, e_peak;
  PqShoulder(double peak_nits, double paper_white_nits, double knee_fraction);
  double map_nits(double nits) const;
  double inverse_nits(double nits) const;
};

// BT.2390-10 §5.4 EETF in the PQ domain, with LB, LW the source (mastering) black and
// peak and Lmin, Lmax the display's:
//   E1 = (PQ(n) - PQ(LB)) / (PQ(LW) - PQ(LB)), minLum, maxLum likewise of Lmin, Lmax,
//   E2 = E1 below KS = 1.5 maxLum - 0.5, the Hermite spline P[E1] from KS to 1,
//   E3 = E2 + b (1 - E2)^4 with b = minLum (the black-level lift),
//   E4 = E3 (PQ(LW) - PQ(LB)) + PQ(LB), out = PQ^-1(E4).
// shape_nits is the EETF without E3, lift_nits is E3 alone (on a shape value), map_nits both
// when black_lift is on. E1 is clipped to [0, 1] (light above the source peak is the source
// peak), except below the source black without the lift: there the EETF is the identity
// E2 = E1 extended below 0, so no light is lifted (with the lift, the source black and what
// is below it land on the display black, as the report maps them).
// E3 lifts the top too (E2 = maxLum gives maxLum + b (1 - maxLum)^4): the curve clips the
// output at the display peak, and that clip is a kink of its own.
struct Bt2390 {
  double e_src_black, e_src_white, min_lum, max_lum, ks;
  bool black_lift;
  double dst_peak_nits = 0;
  Bt2390(double src_black_nits, double src_peak_nits, double dst_black_nits, double dst_peak_nits,
         bool black_lift);
  double shape_nits(double nits) const;
  double lift_nits(double nits) const;
  double map_nits(double nits) const { return black_lift ? lift_nits(shape_nits(nits)) : shape_nits(nits); }
  // Where the slopes jump: the source black and peak (the clips of E1), KS, and with the
  // lift where its output reaches the display peak (input light, and lift input light).
  std::vector<double> kinks_nits() const;
  std::vector<double> lift_kinks_nits() const;
  double lift_reaches_peak_nits() const;  // the shape light whose lift is the display peak, or 0
};

}  // namespace hdrd::tonemap::detail

#include "encode/tone/tonemap_curves.hpp"

#include <algorithm>
#include <limits>

#include "encode/colour/transfer.hpp"

namespace hdrd::tonemap::detail {

HablePiecewise::HablePiecewise(double toe_strength, double toe_length, double shoulder_strength,
                               double shoulder_length, double shoulder_angle, double gamma) {
  // User parameters -> direct parameters (Hable 2017, FilmicToneCurve::CalcDirectParamsFromUser).
  const double perceptual_toe_length = std::pow(toe_length, 2.2);
  double x0 = perceptual_toe_length * 0.5;
  double y0 = (1.0 - toe_strength) * x0;
  const double remaining_y = 1.0 - y0;
  const double initial_w = x0 + remaining_y;
  const double y1_offset = (1.0 - shoulder_length) * remaining_y;
  double x1 = x0 + y1_offset;
  double y1 = y0 + y1_offset;
  const double extra_w = std::exp2(shoulder_strength) - 1.0;
  double w = initial_w + extra_w;
  double overshoot_x = (w * 2.0) * shoulder_angle * shoulder_strength;
  double overshoot_y = 0.5 * shoulder_angle * shoulder_strength;

  // Direct parameters -> curve (FilmicToneCurve::CreateCurve).
  w_ = w;
  inv_w_ = 1.0 / w;
  x0 /= w;
  x1 /= w;
  overshoot_x /= w;
  x0_ = x0;
  x1_ = x1;
  const double m = (y1 - y0) / std::max(x1 - x0, 1e-9);
  const double b = y0 - x0 * m;
  auto slope = [&](double x) { return gamma * m * std::pow(std::max(m * x + b, 1e-12), gamma - 1.0); };
  mid_.offset_x = -(b / m);
  mid_.ln_a = gamma * std::log(m);
  mid_.b = gamma;
  const double toe_m = slope(x0);
  const double shoulder_m = slope(x1);
  y0 = std::max(1e-5, std::pow(y0, gamma));
  y1 = std::max(1e-5, std::pow(y1, gamma));
  overshoot_y = std::pow(1.0 + overshoot_y, gamma) - 1.0;
  auto solve_ab = [](Segment& s, double sx, double sy, double sm) {
    s.b = (sm * sx) / sy;
    s.ln_a = std::log(sy) - s.b * std::log(sx);
  };
  solve_ab(toe_, std::max(x0, 1e-9), y0, toe_m);
  const double sx0 = (1.0 + overshoot_x) - x1;
  const double sy0 = (1.0 + overshoot_y) - y1;
  solve_ab(shoulder_, std::max(sx0, 1e-9), std::max(sy0, 1e-9), shoulder_m);
  shoulder_.offset_x = 1.0 + overshoot_x;
  shoulder_.offset_y = 1.0 + overshoot_y;
  shoulder_.scale_x = -1.0;
  shoulder_.scale_y = -1.0;
  // Normalise so the white point maps to exactly 1.
  const double inv_scale = 1.0 / shoulder_.eval(1.0);
  for (Segment* s : {&toe_, &mid_, &shoulder_}) {
    s->offset_y *= inv_scale;
    s->scale_y *= inv_scale;
  }
}

double HablePiecewise::eval(double x) const {
  const double nx = x * inv_w_;
  if (nx >= 1.0) return 1.0;
  const Segment& s = nx < x0_ ? toe_ : (nx < x1_ ? mid_ : shoulder_);
  return std::clamp(s.eval(nx), 0.0, 1.0);
}

Lottes::Lottes(double contrast, double shoulder_, double hdr_max, double mid_in, double mid_out)
    : a(contrast), d(shoulder_) {
  const double ad = a * d;
  const double denom = (std::pow(hdr_max, ad) - std::pow(mid_in, ad)) * mid_out;
  b = (-std::pow(mid_in, a) + std::pow(hdr_max, a) * mid_out) / denom;
  c = (std::pow(hdr_max, ad) * std::pow(mid_in, a) - std::pow(hdr_max, a) * std::pow(mid_in, ad) * mid_out) /
      denom;
}

Day::Day(double black_point, double white_point, double crossover_point, double toe_strength,
         double shoulder_strength)
    : black(black_point), white(white_point), crossover(crossover_point), toe(toe_strength),
      shoulder(shoulder_strength) {
  k = (1 - toe) * (crossover - black) /
      ((1 - shoulder) * (white - crossover) + (1 - toe) * (crossover - black));
}

double Day::eval(double x) const {
  if (x <= black) return 0.0;
  if (x >= white) return 1.0;
  if (x < crossover) return k * (1 - toe) * (x - black) / (crossover - (1 - toe) * black - toe * x);
  return k + (1 - k) * (x - crossover) / (shoulder * x + (1 - shoulder) * white - crossover);
}

PqShoulder::PqShoulder(double peak_nits, double paper_white_nits, double knee_fraction) {
  e_peak = transfer::pq_inverse_eotf(peak_nits);
  const double e_white = transfer::pq_inverse_eotf(std::min(paper_white_nits, peak_nits));
  // Halfway (knee_fraction) between paper white and peak; at least 10 % of the peak's
  // PQ value below the peak so SDR (peak = paper white) still gets a shoulder.
  const double room = std::max(knee_fraction * (e_peak - e_white), 0.1 * e_peak);
  e_knee = e_peak - room;
}

double PqShoulder::map_nits(double nits) const {
  const double e = transfer::pq_inverse_eotf(nits);
  if (e <= e_knee) return std::max(nits, 0.0);
  const double room = e_peak - e_knee;
  return transfer::pq_eotf(e_knee + room * (1.0 - std::exp(-(e - e_knee) / room)));
}

namespace {
// ST 2084's inverse-EOTF formula keeps working above 10000 cd/m2 (E' approaches
// (c2/c3)^m2 ~ 1.99); the shoulder needs that to invert scene values beyond PQ's range.
double pq_eotf_unclamped(double e) {
  const double p = std::pow(std::max(e, 0.0), 1.0 / transfer::kPqM2);
  const double den = transfer::kPqC2 - transfer::kPqC3 * p;
  if (den <= 0) return std::numeric_limits<double>::infinity();
  return transfer::kPqPeakNits * std::pow(std::max(p - transfer::kPqC1, 0.0) / den, 1.0 / transfer::kPqM1);
}
}  // namespace

double PqShoulder::inverse_nits(double nits) const {
  const double e = transfer::pq_inverse_eotf(nits);
  if (e <= e_knee) return std::max(nits, 0.0);
  const double room = e_peak - e_knee;
  const double t = (e - e_knee) / room;
  if (t >= 1.0) return std::numeric_limits<double>::infinity();
  return pq_eotf_unclamped(e_knee - room * std::log(1.0 - t));
}

Bt2390::Bt2390(double src_black_nits, double src_peak_nits, double dst_black_nits, double dst_peak_nits,
               bool lift)
    : black_lift(lift), dst_peak_nits(dst_peak_nits) {
  e_src_black = transfer::pq_inverse_eotf(src_black_nits);
  e_src_white = transfer::pq_inverse_eotf(src_peak_nits);
  const double range = e_src_white - e_src_black;
  min_lum = (transfer::pq_inverse_eotf(dst_black_nits) - e_src_black) / range;
  max_lum = (transfer::pq_inverse_eotf(dst_peak_nits) - e_src_black) / range;
  ks = 1.5 * max_lum - 0.5;
}

double Bt2390::shape_nits(double nits) const {
  const double range = e_src_white - e_src_black;
  const double e1 = (transfer::pq_inverse_eotf(nits) - e_src_black) / range;
  if (e1 < 0) return black_lift ? transfer::pq_eotf(e_src_black) : std::max(nits, 0.0);
  if (e1 < ks || ks >= 1.0) return e1 < 1.0 ? nits : transfer::pq_eotf(e_src_white);
  // BT.2390 eq. (5.4-2): Hermite spline from (KS, KS) with slope 1 to (1, maxLum) with slope 0.
  const double t = (std::min(e1, 1.0) - ks) / (1.0 - ks);
  const double t2 = t * t, t3 = t2 * t;
  const double e2 = (2 * t3 - 3 * t2 + 1) * ks + (t3 - 2 * t2 + t) * (1 - ks) + (-2 * t3 + 3 * t2) * max_lum;
  return transfer::pq_eotf(e2 * range + e_src_black);
}

double Bt2390::lift_nits(double nits) const {
  const double range = e_src_white - e_src_black;
  const double e2 = std::clamp((transfer::pq_inverse_eotf(nits) - e_src_black) / range, 0.0, 1.0);
  const double e3 = e2 + min_lum * std::pow(1.0 - e2, 4.0);
  return transfer::pq_eotf(e3 * range + e_src_black);
}

double Bt2390::lift_reaches_peak_nits() const {
  if (!black_lift) return 0;
  // The largest light the roll-off gives: the display peak below the corner, else the source peak.
  double hi = shape_nits(transfer::kPqPeakNits), lo = transfer::pq_eotf(e_src_black);
  if (!(lift_nits(hi) > dst_peak_nits)) return 0;
  for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {  // lift is increasing (b < 1/4)
    const double mid = 0.5 * (lo + hi);
    (lift_nits(mid) > dst_peak_nits ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

std::vector<double> Bt2390::kinks_nits() const {
  const double range = e_src_white - e_src_black;
  std::vector<double> k = {transfer::pq_eotf(e_src_black), transfer::pq_eotf(e_src_white)};
  if (ks < 1.0) k.push_back(transfer::pq_eotf(ks * range + e_src_black));
  if (const double n = lift_reaches_peak_nits(); n > 0) {
    // The input whose roll-off gives n (shape is increasing up to the source peak).
    double lo = 0, hi = transfer::pq_eotf(e_src_white);
    for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {
      const double mid = 0.5 * (lo + hi);
      (shape_nits(mid) < n ? lo : hi) = mid;
    }
    k.push_back(0.5 * (lo + hi));
  }
  return k;
}

std::vector<double> Bt2390::lift_kinks_nits() const {
  std::vector<double> k = {transfer::pq_eotf(e_src_black), transfer::pq_eotf(e_src_white)};
  if (const double n = lift_reaches_peak_nits(); n > 0) k.push_back(n);
  return k;
}

}  // namespace hdrd::tonemap::detail

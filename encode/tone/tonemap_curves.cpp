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

namespace hdrd::tonemap::detail {

namespace {
double mix(double a, double b, double t) { return a + (b - a) * t; }
// GLSL smoothstep (edge0 > edge1 allowed: it then falls from 1 to 0).
double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}
}  // namespace

Knee pick_knee(double src_peak_nits, double src_avg_nits, double dst_peak_nits, const KneeParams& k) {
  const double s_max = transfer::pq_inverse_eotf(src_peak_nits), d_max = transfer::pq_inverse_eotf(dst_peak_nits);
  double s_knee = src_avg_nits > 0 ? transfer::pq_inverse_eotf(src_avg_nits) : k.default_knee * s_max;
  s_knee = std::clamp(s_knee, k.minimum * s_max, k.maximum * s_max);
  const double r = s_knee / s_max, adapted = r * d_max;
  const double tuning = 1 - smoothstep(k.maximum, k.default_knee, r) * smoothstep(k.minimum, k.default_knee, r);
  const double a = mix(k.adaptation, 1.0, tuning);
  const double d_knee = std::clamp(mix(s_knee, adapted, a), k.minimum * d_max, k.maximum * d_max);
  return {s_knee, d_knee};
}

Spline::Spline(double src_peak, double src_avg, double dst_peak, const KneeParams& k, double contrast,
               double slope_tuning, double slope_offset)
    : src_peak_nits(src_peak), dst_peak_nits(dst_peak) {
  identity = !(src_peak > dst_peak);
  if (identity) return;
  knee = pick_knee(src_peak, src_avg, dst_peak, k);
  const double sp = knee.src_pq, dp = knee.dst_pq;
  const double s_max = transfer::pq_inverse_eotf(src_peak), d_max = transfer::pq_inverse_eotf(dst_peak);
  const double ratio = std::clamp(slope_tuning * (src_peak / dst_peak - 1), slope_offset, 1 + slope_offset);
  const double in_min = -sp, in_max = s_max - sp, out_min = -dp, out_max = d_max - dp;
  slope = std::pow(dp / sp, (1 - contrast) * ratio);
  slope = std::min({slope, 2 * dp / sp, 3 * out_max / in_max});
  pa = (out_min - slope * in_min) / (in_min * in_min);
  const double t = 2 * in_max * in_max;
  qa = (slope * in_max - out_max) / (in_max * t);
  qb = -3 * (slope * in_max - out_max) / t;
}

double Spline::map_nits(double nits) const {
  if (!(nits > 0)) return 0.0;
  if (identity) return std::min(nits, src_peak_nits);
  if (nits >= src_peak_nits) return dst_peak_nits;
  const double u = transfer::pq_inverse_eotf(nits) - knee.src_pq;
  const double v = u > 0 ? ((qa * u + qb) * u + slope) * u : (pa * u + slope) * u;
  return std::min(transfer::pq_eotf(std::max(v + knee.dst_pq, 0.0)), dst_peak_nits);
}

Mobius::Mobius(double src_peak, double dst_peak, double knee) : src_peak_nits(src_peak), dst_peak_nits(dst_peak), j(knee) {
  identity = !(src_peak > dst_peak);
  if (identity) return;
  const double peak = src_peak / dst_peak;
  a = -j * j * (peak - 1) / (j * j - 2 * j + peak);
  b = (j * j - 2 * j * peak + peak) / (peak - 1);
  scale = (b * b + 2 * b * j + j * j) / (b - a);
}

double Mobius::map_nits(double nits) const {
  if (!(nits > 0)) return 0.0;
  if (identity) return std::min(nits, src_peak_nits);
  const double x = std::min(nits, src_peak_nits) / dst_peak_nits;
  return std::min(x <= j ? x : scale * (x + a) / (x + b), 1.0) * dst_peak_nits;
}

Bt2446a::Bt2446a(double src_peak, double dst_peak)
    : src_peak_nits(src_peak), dst_peak_nits(dst_peak),
      rho_hdr(1 + 32 * std::pow(src_peak / 10000, 1 / 2.4)), rho_sdr(1 + 32 * std::pow(dst_peak / 10000, 1 / 2.4)) {}

double Bt2446a::tone(double yp) {
  if (yp <= kBt2446aJoin1) return 1.0770 * yp;
  auto quadratic = [](double v) { return (-1.1510 * v + 2.7811) * v - 0.6302; };
  if (yp < kBt2446aJoin2) return quadratic(yp);
  const double step = 0.5 * kBt2446aJoin2 + 0.5 - quadratic(kBt2446aJoin2);
  return 0.5 * yp + 0.5 - step * std::max(1 - yp, 0.0) / (1 - kBt2446aJoin2);
}

double Bt2446a::map_nits(double nits) const {
  if (!(nits > 0)) return 0.0;
  const double y = std::pow(std::min(nits, src_peak_nits) / src_peak_nits, 1 / 2.4);
  const double yp = std::log(1 + (rho_hdr - 1) * y) / std::log(rho_hdr);
  const double ysdr = (std::pow(rho_sdr, tone(yp)) - 1) / (rho_sdr - 1);
  return std::min(std::pow(ysdr, 2.4), 1.0) * dst_peak_nits;
}

std::vector<double> Bt2446a::kinks_nits() const {
  // Y'p = j: Y' = (rho^j - 1) / (rho - 1), light = L_HDR Y'^2.4.
  std::vector<double> k;
  for (double j : {kBt2446aJoin1, kBt2446aJoin2})
    k.push_back(src_peak_nits * std::pow((std::pow(rho_hdr, j) - 1) / (rho_hdr - 1), 2.4));
  k.push_back(src_peak_nits);
  return k;
}

St2094_40::St2094_40(double src_peak, double src_avg, double dst_peak, const KneeParams& k)
    : src_peak_nits(src_peak), dst_peak_nits(dst_peak) {
  identity = !(src_peak > dst_peak);
  if (identity) return;
  const Knee knee = pick_knee(src_peak, src_avg, dst_peak, k);
  kx = transfer::pq_eotf(knee.src_pq) / src_peak;
  ky = transfer::pq_eotf(knee.dst_pq) / dst_peak;
  const double m = ky / kx * (1 - kx) / (1 - ky);
  const int n = std::clamp(static_cast<int>(std::ceil(m)), 2, 16);
  anchors.assign(static_cast<std::size_t>(n) + 1, 1.0);
  anchors[0] = 0;
  anchors[1] = std::min(m / n, 1.0);
}

double St2094_40::map_nits(double nits) const {
  if (!(nits > 0)) return 0.0;
  if (identity) return std::min(nits, src_peak_nits);
  const double x = std::min(nits / src_peak_nits, 1.0);
  if (x <= kx) return x * ky / kx * dst_peak_nits;
  const double t = (x - kx) / (1 - kx);
  const int n = static_cast<int>(anchors.size()) - 1;
  // Bernstein sum with running binomial coefficients.
  double b = 0, binom = 1;
  for (int i = 0; i <= n; ++i) {
    b += binom * std::pow(t, i) * std::pow(1 - t, n - i) * anchors[static_cast<std::size_t>(i)];
    binom = binom * (n - i) / (i + 1);
  }
  return std::min(ky + (1 - ky) * b, 1.0) * dst_peak_nits;
}

St2094_10::St2094_10(double src_peak, double src_avg, double dst_peak, const KneeParams& k)
    : src_peak_nits(src_peak), dst_peak_nits(dst_peak) {
  identity = !(src_peak > dst_peak);
  if (identity) return;
  const Knee knee = pick_knee(src_peak, src_avg, dst_peak, k);
  const double x1 = 0, x2 = transfer::pq_eotf(knee.src_pq), x3 = src_peak;
  const double y1 = 0, y2 = transfer::pq_eotf(knee.dst_pq), y3 = dst_peak;
  // y_i (1 + c3 x_i) = c1 + c2 x_i for the three anchors, solved by Cramer's rule.
  const double det = x3 * y3 * (x1 - x2) + x2 * y2 * (x3 - x1) + x1 * y1 * (x2 - x3);
  c1 = (x2 * x3 * (y2 - y3) * y1 + x1 * x3 * (y3 - y1) * y2 + x1 * x2 * (y1 - y2) * y3) / det;
  c2 = ((x3 * y3 - x2 * y2) * y1 + (x1 * y1 - x3 * y3) * y2 + (x2 * y2 - x1 * y1) * y3) / det;
  c3 = ((x3 - x2) * y1 + (x1 - x3) * y2 + (x2 - x1) * y3) / det;
}

double St2094_10::map_nits(double nits) const {
  if (!(nits > 0)) return 0.0;
  if (identity) return std::min(nits, src_peak_nits);
  const double x = std::min(nits, src_peak_nits);
  return std::clamp((c1 + c2 * x) / (1 + c3 * x), 0.0, dst_peak_nits);
}

}  // namespace hdrd::tonemap::detail

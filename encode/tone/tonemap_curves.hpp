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


// ---- Curves that compress a source (mastering) range [0, source peak] into the display's
// [0, display peak], all in cd/m2. Light above the source peak is the source peak; where the
// display peak is at or above the source peak there is nothing to compress and each is the
// identity up to the source peak. None lifts black (every source and display minimum is 0).

// The knee (pivot) of libplacebo's ST 2094-10-inspired brightness matching
// (pl_tone_map_constants, src/tone_mapping.c st2094_pick_knee), in PQ signals s (source) and
// d (display) with s_max = PQ(source peak), d_max = PQ(display peak):
//   s_knee = PQ(scene average) (knee_default * s_max when the average is unknown), clamped to
//            [knee_min, knee_max] * s_max;  r = s_knee / s_max;  adapted = r * d_max;
//   tuning = 1 - smoothstep(knee_max, knee_default, r) * smoothstep(knee_min, knee_default, r);
//   a = mix(knee_adaptation, 1, tuning);  d_knee = mix(s_knee, adapted, a) clamped to
//            [knee_min, knee_max] * d_max.
// knee_min = 0.1 and knee_max = 0.8 as libplacebo's defaults.
struct KneeParams {
  double adaptation = 0.4, minimum = 0.1, maximum = 0.8, default_knee = 0.4;
};
struct Knee {
  double src_pq, dst_pq;  // the pivot, PQ signals
};
Knee pick_knee(double src_peak_nits, double src_avg_nits, double dst_peak_nits, const KneeParams& k);

// libplacebo's default curve (src/tone_mapping.c "spline"), in the PQ domain with the pivot
// (s_p, d_p) from pick_knee: slope m = d_p / s_p raised to (1 - contrast) * clamp(tuning *
// (Lw / Ld - 1), offset, 1 + offset); below the pivot P(u) = Pa u^2 + m u with P(-s_p) = -d_p;
// above it Q(u) = Qa u^3 + Qb u^2 + m u with Q(s_max - s_p) = d_max - d_p and Q'' = 0 there
// (u = s - s_p). m is held at or below 2 d_p / s_p and 3 (d_max - d_p) / (s_max - s_p), the
// slopes past which P or Q would turn back (libplacebo does not; its defaults stay below).
struct Spline {
  double src_peak_nits, dst_peak_nits;
  Knee knee{};
  double slope = 1, pa = 0, qa = 0, qb = 0;
  bool identity = false;  // display peak >= source peak
  Spline(double src_peak_nits, double src_avg_nits, double dst_peak_nits, const KneeParams& k, double contrast,
         double slope_tuning, double slope_offset);
  double map_nits(double nits) const;
};

// Mobius (mpv, libplacebo src/tone_mapping.c "mobius") in units of the display peak, with
// p = Lw / Ld and knee j: x below j is kept, above it M(x) = scale (x + a) / (x + b) with
// M(j) = j, M'(j) = 1, M(p) = 1.
struct Mobius {
  double src_peak_nits, dst_peak_nits, j, a = 0, b = 0, scale = 1;
  bool identity = false;
  Mobius(double src_peak_nits, double dst_peak_nits, double knee);
  double map_nits(double nits) const;
};

// ITU-R BT.2446-1 method A (HDR to SDR, its tone-mapping steps) on luma, in linear
// light: Y' = (Y / L_HDR)^(1/2.4); rho_HDR = 1 + 32 (L_HDR / 10000)^(1/2.4);
// Y'p = log(1 + (rho_HDR - 1) Y') / log(rho_HDR); Y'c = 1.0770 Y'p (Y'p <= 0.7399),
// -1.1510 Y'p^2 + 2.7811 Y'p - 0.6302 (< 0.9909), 0.5 Y'p + 0.5 above;
// Y'sdr = (rho_SDR^Y'c - 1) / (rho_SDR - 1); Y = L_SDR Y'sdr^2.4 (BT.1886, black 0).
// The published pieces, rounded to four digits, do not quite meet: at 0.7399 the quadratic
// starts 5.5e-4 above the line (a step up, which a table cannot follow). Here the line
// hands over where the quadratic crosses it, Y'p = 0.718480 (a slope kink, 1.077 to
// 1.127, no step): over [0.71848, 0.7399] Y'c is the quadratic, at most 5.5e-4 above the
// published line. At 0.9909 the line starts 5.1e-6 above the quadratic's end: the line
// bends in by that much at 0.9909, falling linearly to nothing at Y'p = 1 (the peak is
// still the peak), so the curve has no step there either.
inline constexpr double kBt2446aJoin1 = 0.7184796505224301, kBt2446aJoin2 = 0.9909;
struct Bt2446a {
  double src_peak_nits, dst_peak_nits, rho_hdr, rho_sdr;
  Bt2446a(double src_peak_nits, double dst_peak_nits);
  static double tone(double yp);  // Y'p -> Y'c
  double map_nits(double nits) const;
  std::vector<double> kinks_nits() const;  // the pieces' joins and the source peak
};

// SMPTE ST 2094-40 Annex B basis OOTF without metadata, as libplacebo builds it from the
// target peak (src/tone_mapping.c st2094_40): x = L / Lw, knee Kx = knee_src / Lw,
// Ky = knee_dst / Ld (pick_knee, in linear light); y = (Ky / Kx) x below Kx, above it
// y = Ky + (1 - Ky) B_N((x - Kx) / (1 - Kx)), B_N(t) = sum_k C(N, k) t^k (1 - t)^(N - k) P_k
// with P_0 = 0, P_1 = min(m / N, 1), P_2..P_N = 1, m = Ky / Kx (1 - Kx) / (1 - Ky) and
// N = clamp(ceil(m), 2, 16): C1 at the knee. Output L = y Ld.
struct St2094_40 {
  double src_peak_nits, dst_peak_nits, kx = 0, ky = 0;
  std::vector<double> anchors;  // P_0 .. P_N
  bool identity = false;
  St2094_40(double src_peak_nits, double src_avg_nits, double dst_peak_nits, const KneeParams& k);
  double map_nits(double nits) const;
};

// SMPTE ST 2094-10 Annex B tone curve y = (c1 + c2 x^n) / (1 + c3 x^n) with n = 1 through
// three anchors (x1, y1) = (0, 0) (source and display minimum), (x2, y2) = the knee from the
// scene average (pick_knee) and (x3, y3) = (Lw, Ld), in linear cd/m2 as libplacebo
// evaluates it (src/tone_mapping.c st2094_10).
struct St2094_10 {
  double src_peak_nits, dst_peak_nits, c1 = 0, c2 = 1, c3 = 0;
  bool identity = false;
  St2094_10(double src_peak_nits, double src_avg_nits, double dst_peak_nits, const KneeParams& k);
  double map_nits(double nits) const;
};

}  // namespace hdrd::tonemap::detail

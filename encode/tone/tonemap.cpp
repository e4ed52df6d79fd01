// The tone-curve registry: built-in curves as data entries (name, description, source,
// parameters, default application, inverse) plus run-time registration.
#include "encode/tone/tonemap.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <functional>
#include <mutex>

#include <fmt/format.h>

#include "encode/tone/tonemap_curves.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::tonemap {

using color::Vec3;

std::string_view to_string(Apply a) {
  switch (a) {
    case Apply::per_channel: return "per-channel";
    case Apply::max_rgb: return "max-rgb";
    case Apply::luminance: return "luminance";
    case Apply::rgb: return "rgb";
  }
  return "?";
}

std::optional<Apply> parse_apply(std::string_view s) {
  for (Apply a : {Apply::per_channel, Apply::max_rgb, Apply::luminance, Apply::rgb})
    if (to_string(a) == s) return a;
  return std::nullopt;
}

Vec3 Curve::map_rgb(Vec3 rgb, Apply apply) const {
  const Vec3 c{std::max(rgb.x, 0.0), std::max(rgb.y, 0.0), std::max(rgb.z, 0.0)};
  switch (apply) {
    case Apply::per_channel:
    case Apply::rgb:
      return {map(c.x), map(c.y), map(c.z)};
    case Apply::max_rgb:
    case Apply::luminance: {
      const double k = apply == Apply::max_rgb ? std::max({c.x, c.y, c.z}) : color::dot(color::kRec2020Luma, c);
      const Vec3 y = k > 0 ? c * (shape(k) / k) : Vec3{};
      return lifts_black() ? Vec3{lift(y.x), lift(y.y), lift(y.z)} : y;
    }
  }
  return c;
}

namespace {

using detail::Hable;

double param(const ParamValues& p, const char* name) { return p.at(name); }

detail::KneeParams knee_of(const ParamValues& p) {
  detail::KneeParams k;
  k.adaptation = param(p, "knee_adaptation");
  k.default_knee = param(p, "knee_default");
  return k;
}

// Strictly increasing curve on [0, W): invert by bisection in log space.
std::optional<double> bisect_inverse(const Curve& c, double y, double max_y) {
  if (y <= 0) return 0.0;
  if (y >= max_y) return std::nullopt;
  double lo = 0, hi = 1;
  while (c.map(hi) < y) {
    hi *= 2;
    if (hi > 1e30) return std::nullopt;
  }
  for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (c.map(mid) < y ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// A scalar curve from a lambda: map, optional analytic inverse, its kinks.
class LambdaCurve : public Curve {
 public:
  using Fn = std::function<double(double)>;
  LambdaCurve(double max_y, Fn map, Fn inverse = {}, std::vector<double> kinks = {})
      : max_y_(max_y), map_(std::move(map)), inv_(std::move(inverse)), kinks_(std::move(kinks)) {}
  double map(double x) const override { return std::clamp(map_(std::max(x, 0.0)), 0.0, max_y_); }
  std::optional<double> inverse(double y) const override {
    if (y < 0 || y >= max_y_) return std::nullopt;
    if (inv_) return inv_(y);
    return bisect_inverse(*this, y, max_y_);
  }
  std::vector<double> kinks() const override { return kinks_; }

 private:
  double max_y_;
  Fn map_, inv_;
  std::vector<double> kinks_;
};

template <class... A>
std::unique_ptr<Curve> make(A&&... a) {
  return std::make_unique<LambdaCurve>(std::forward<A>(a)...);
}

// BT.2390-10 §5.4 EETF (tonemap_curves.hpp) in paper-white units, split as the report's
// steps: shape = E1, E2 (Hermite roll-off above KS), E4; lift = E3, the black-level lift.
class Bt2390Curve : public Curve {
 public:
  Bt2390Curve(const detail::Bt2390& e, const Display& d) : e_(e), pw_(d.paper_white_nits), max_y_(d.max_y()) {}
  double map(double x) const override { return std::clamp(e_.map_nits(std::max(x, 0.0) * pw_) / pw_, 0.0, max_y_); }
  double shape(double x) const override {
    return std::clamp(e_.shape_nits(std::max(x, 0.0) * pw_) / pw_, 0.0, max_y_);
  }
  bool lifts_black() const override { return e_.black_lift; }
  double lift(double y) const override { return std::clamp(e_.lift_nits(std::max(y, 0.0) * pw_) / pw_, 0.0, max_y_); }
  std::optional<double> inverse(double y) const override { return bisect_inverse(*this, y, max_y_); }
  std::vector<double> kinks() const override { return scaled(e_.kinks_nits()); }
  std::vector<double> lift_kinks() const override { return scaled(e_.lift_kinks_nits()); }

 private:
  std::vector<double> scaled(std::vector<double> nits) const {
    for (double& n : nits) n /= pw_;
    return nits;
  }
  detail::Bt2390 e_;
  double pw_, max_y_;
};

// ---- RGB operators ---------------------------------------------------------------------

// Khronos PBR Neutral (2024, KhronosGroup/ToneMapping), made peak-aware as W * f(rgb / W).
class PbrNeutral : public Curve {
 public:
  PbrNeutral(double w, double start, double desat) : w_(w), start_(start), desat_(desat) {}
  Vec3 neutral(Vec3 c) const {
    const double x = std::min({c.x, c.y, c.z});
    const double offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    c = c - Vec3{offset, offset, offset};
    const double peak = std::max({c.x, c.y, c.z});
    if (peak < start_) return c;
    const double d = 1.0 - start_;
    const double new_peak = 1.0 - d * d / (peak + d - start_);
    c = c * (new_peak / peak);
    const double g = 1.0 - 1.0 / (desat_ * (peak - new_peak) + 1.0);
    return c * (1.0 - g) + Vec3{new_peak, new_peak, new_peak} * g;
  }
  double map(double x) const override { return map_rgb({x, x, x}, Apply::rgb).y; }
  Vec3 map_rgb(Vec3 rgb, Apply) const override {
    const Vec3 c{std::max(rgb.x, 0.0), std::max(rgb.y, 0.0), std::max(rgb.z, 0.0)};
    const Vec3 n = neutral(c * (1.0 / w_));
    return Vec3{std::clamp(n.x, 0.0, 1.0), std::clamp(n.y, 0.0, 1.0), std::clamp(n.z, 0.0, 1.0)} * w_;
  }

 private:
  double w_, start_, desat_;
};

// AgX (Sobotka), minimal 6th-order polynomial fit (bwrensch 2023; used by three.js,
// Godot): inset matrix, log2 encoding over [min_ev, max_ev] around mid grey, sigmoid,
// outset matrix, then the 2.2 display power to linear. Applied in the working space.
class Agx : public Curve {
 public:
  Agx(double w, double min_ev, double max_ev) : w_(w), min_ev_(min_ev), max_ev_(max_ev) {}
  double map(double x) const override { return map_rgb({x, x, x}, Apply::rgb).y; }
  Vec3 map_rgb(Vec3 rgb, Apply) const override {
    // Matrices as published (GLSL column-major), written here row-major.
    static constexpr color::Mat3 kInset{{{{0.842479062253094, 0.0784335999999992, 0.0792237451477643},
                                          {0.0423282422610123, 0.878468636469772, 0.0791661274605434},
                                          {0.0423756549057051, 0.0784336, 0.879142973793104}}}};
    static constexpr color::Mat3 kOutset{{{{1.19687900512017, -0.0980208811401368, -0.0990297440797205},
                                           {-0.0528968517574562, 1.15190312990417, -0.0989611768448433},
                                           {-0.0529716355144438, -0.0980434501171241, 1.15107367264116}}}};
    Vec3 v = kInset * (Vec3{std::max(rgb.x, 0.0), std::max(rgb.y, 0.0), std::max(rgb.z, 0.0)} * (1.0 / w_));
    auto encode = [&](double c) {
      const double ev = std::clamp(std::log2(std::max(c, 1e-10)), min_ev_, max_ev_);
      const double t = (ev - min_ev_) / (max_ev_ - min_ev_);
      const double t2 = t * t, t4 = t2 * t2;
      return 15.5 * t4 * t2 - 40.14 * t4 * t + 31.96 * t4 - 6.868 * t2 * t + 0.4298 * t2 + 0.1191 * t - 0.00232;
    };
    v = kOutset * Vec3{encode(v.x), encode(v.y), encode(v.z)};
    auto lin = [&](double c) { return std::pow(std::clamp(c, 0.0, 1.0), 2.2) * w_; };
    // At x = 0 the sigmoid is slightly negative: clamp so black is never lifted.
    return {lin(v.x), lin(v.y), lin(v.z)};
  }

 private:
  double w_, min_ev_, max_ev_;
};

// Frostbite-style display mapper (Fry, "High Dynamic Range Color Grading and Display in
// Frostbite", GDC 2017): tone-map ICtCp intensity with the PQ shoulder, desaturate toward
// the achromatic axis as intensity is compressed, optionally let the hue drift toward the
// per-channel result (hue_shift = 0: constant hue).
class IctcpMapper : public Curve {
 public:
  IctcpMapper(const Display& d, double knee, double desaturation, double hue_shift)
      : d_(d), shoulder_(d.peak_nits, d.paper_white_nits, knee), desat_(desaturation), hue_shift_(hue_shift) {}
  double map(double x) const override {
    return std::min(shoulder_.map_nits(std::max(x, 0.0) * d_.paper_white_nits) / d_.paper_white_nits, d_.max_y());
  }
  std::optional<double> inverse(double y) const override {
    if (y < 0 || y >= d_.max_y()) return std::nullopt;
    return shoulder_.inverse_nits(y * d_.paper_white_nits) / d_.paper_white_nits;
  }
  Vec3 map_rgb(Vec3 rgb, Apply) const override {
    const Vec3 c{std::max(rgb.x, 0.0), std::max(rgb.y, 0.0), std::max(rgb.z, 0.0)};
    const Vec3 nits = c * d_.paper_white_nits;
    const Vec3 ictcp = color::rec2020_nits_to_ictcp(nits);
    if (!(ictcp.x > 0)) return {};
    const double i_out = transfer::pq_inverse_eotf(shoulder_.map_nits(transfer::pq_eotf(ictcp.x)));
    const double ratio = std::min(1.0, i_out / ictcp.x);
    double chroma_scale = std::pow(ratio, desat_);
    double ct = ictcp.y * chroma_scale, cp = ictcp.z * chroma_scale;
    if (hue_shift_ > 0) {
      const Vec3 pc{shoulder_.map_nits(nits.x), shoulder_.map_nits(nits.y), shoulder_.map_nits(nits.z)};
      const Vec3 pc_ictcp = color::rec2020_nits_to_ictcp(pc);
      const double h0 = std::atan2(cp, ct), h1 = std::atan2(pc_ictcp.z, pc_ictcp.y);
      double dh = std::remainder(h1 - h0, 2 * M_PI);
      const double h = h0 + hue_shift_ * dh, r = std::hypot(ct, cp);
      ct = r * std::cos(h);
      cp = r * std::sin(h);
    }
    return color::ictcp_to_rec2020_nits({i_out, ct, cp}) * (1.0 / d_.paper_white_nits);
  }

 private:
  Display d_;
  detail::PqShoulder shoulder_;
  double desat_, hue_shift_;
};

// ---- The built-in table ------------------------------------------------------------------

std::vector<ToneCurveInfo> builtins() {
  std::vector<ToneCurveInfo> v;
  v.push_back({"clip", "Linear, clipped at the display peak: nits = min(x * paper_white, peak)",
               "REFERENCE.md §1.3", {}, Apply::per_channel, true, true, true,
               [](const Display& d, const ParamValues&) {
                 const double w = d.max_y();
                 return make(w, [w](double x) { return std::min(x, w); }, [](double y) { return y; }, std::vector<double>{w});
               }});
  v.push_back({"pq-shoulder",
               "Linear to a knee halfway (in PQ) between paper white and peak, then an exponential "
               "shoulder into the peak; hdrd's default",
               "hdrd (BT.2390-10 §5.4 idea with a C1 exponential shoulder)",
               {{"knee", "knee position as a fraction of the PQ room between paper white and peak", 0.05, 1.0, 0.5}},
               Apply::max_rgb, true, true, true,
               [](const Display& d, const ParamValues& p) {
                 auto s = std::make_shared<detail::PqShoulder>(d.peak_nits, d.paper_white_nits, param(p, "knee"));
                 const double pw = d.paper_white_nits;
                 return make(d.max_y(), [s, pw](double x) { return s->map_nits(x * pw) / pw; },
                             [s, pw](double y) { return s->inverse_nits(y * pw) / pw; });
               }});
  v.push_back({"reinhard", "Reinhard et al. 2002 global operator x/(1+x), stretched to the display maximum",
               "Reinhard et al., Photographic Tone Reproduction, SIGGRAPH 2002, eq. 3", {},
               Apply::luminance, true, true, false,
               [](const Display& d, const ParamValues&) {
                 const double w = d.max_y();
                 return make(w, [w](double x) { return x / (1 + x / w); },
                             [w](double y) { return y / (1 - y / w); });
               }});
  v.push_back({"reinhard-extended", "Reinhard with a white point: scene value `white` reaches the display peak",
               "Reinhard et al. 2002, eq. 4",
               {{"white", "relative scene value that maps to the display peak", 0.1, 1e6, 8.0}},
               Apply::luminance, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), wu = param(p, "white") / w, w2 = wu * wu;
                 return make(
                     w, [=](double x) { const double u = std::min(x / w, wu); return w * u * (1 + u / w2) / (1 + u); },
                     [=](double y) {
                       const double t = y / w, b = 1 - t;
                       return w * (-b + std::sqrt(b * b + 4 * t / w2)) * w2 / 2;
                     },
                     std::vector<double>{param(p, "white")});
               }});
  v.push_back({"drago", "Drago et al. adaptive logarithmic mapping, display-luminance aware",
               "Drago et al., Adaptive Logarithmic Mapping, Eurographics 2003, eq. 4",
               {{"bias", "bias b: contrast in dark areas (0.85 recommended)", 0.5, 1.0, 0.85},
                {"scene_max", "largest relative scene value (maps to the peak)", 1.0, 1e6, 100.0}},
               Apply::luminance, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), lmax = param(p, "scene_max");
                 const double e = std::log(param(p, "bias")) / std::log(0.5);
                 return make(w, [=](double x) {
                   x = std::min(x, lmax);
                   // Ld / Ld_max = ln(x + 1) / (log10(Lw_max + 1) ln(2 + 8 (x / Lw_max)^e)): 1 at x = Lw_max.
                   return w * std::log(x + 1) / (std::log10(lmax + 1) * std::log(2 + 8 * std::pow(x / lmax, e)));
                 }, LambdaCurve::Fn{}, std::vector<double>{lmax});
               }});
  v.push_back({"hable", "Hable \"Uncharted 2\" filmic curve (Duiker), normalised by the white point",
               "Hable, Filmic Tonemapping Operators, 2010 (A=.15 B=.50 C=.10 D=.20 E=.02 F=.30, W=11.2)",
               {{"white", "linear white point", 1.0, 1e4, 11.2},
                {"exposure_bias", "input multiplier (Uncharted 2 used 2.0)", 0.01, 100, 1.0}},
               Apply::per_channel, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), white = param(p, "white"), bias = param(p, "exposure_bias");
                 const Hable h;
                 const double norm = h.raw(white);
                 return make(w, [=](double x) { return w * std::min(h.raw(std::min(bias * x / w, white)) / norm, 1.0); },
                             LambdaCurve::Fn{}, std::vector<double>{white * w / bias});
               }});
  v.push_back({"hable-piecewise", "Hable's piecewise power curve (toe, linear section, shoulder)",
               "Hable, Filmic Tonemapping with Piecewise Power Curves, 2017",
               {{"toe_strength", "toe strength", 0.0, 1.0, 0.5},
                {"toe_length", "toe length", 0.0, 1.0, 0.5},
                {"shoulder_strength", "shoulder strength (stops of extra range)", 0.0, 10.0, 2.0},
                {"shoulder_length", "shoulder length", 1e-5, 1.0, 0.5},
                {"shoulder_angle", "shoulder angle (overshoot)", 0.0, 1.0, 1.0},
                {"gamma", "gamma of the curve", 0.2, 5.0, 1.0}},
               Apply::per_channel, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y();
                 auto c = std::make_shared<detail::HablePiecewise>(
                     param(p, "toe_strength"), param(p, "toe_length"), param(p, "shoulder_strength"),
                     param(p, "shoulder_length"), param(p, "shoulder_angle"), param(p, "gamma"));
                 std::vector<double> kinks = c->kinks();
                 for (double& k : kinks) k *= w;
                 return make(w, [=](double x) { return w * c->eval(x / w); }, LambdaCurve::Fn{}, std::move(kinks));
               }});
  v.push_back({"day", "Day's user-friendly operator (Insomniac): rational toe and shoulder",
               "Day, An efficient and user-friendly tone mapping operator, Insomniac Games 2012",
               {{"black", "black point (scene values below map to 0)", 0.0, 0.5, 0.0},
                {"white", "white point (maps to the peak)", 1.0, 1e4, 8.0},
                {"crossover", "where toe and shoulder meet", 0.01, 100.0, 0.3},
                {"toe", "toe strength", 0.0, 0.99, 0.3},
                {"shoulder", "shoulder strength", 0.0, 0.99, 0.8}},
               Apply::per_channel, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y();
                 auto c = std::make_shared<detail::Day>(param(p, "black"), param(p, "white"), param(p, "crossover"),
                                                        param(p, "toe"), param(p, "shoulder"));
                 std::vector<double> kinks = c->kinks();
                 for (double& k : kinks) k *= w;
                 return make(w, [=](double x) { return w * c->eval(x / w); }, LambdaCurve::Fn{}, std::move(kinks));
               }});
  v.push_back({"lottes", "Lottes' contrast/shoulder curve, SDR parameters, stretched to the display maximum",
               "Lottes, Advanced Techniques and Optimization of HDR Color Pipelines, GDC 2016",
               {{"contrast", "a", 1.0, 3.0, 1.6},
                {"shoulder", "d", 0.5, 1.5, 0.977},
                {"hdr_max", "scene value that reaches the peak", 1.0, 1e4, 8.0},
                {"mid_in", "mid-grey input", 0.01, 1.0, 0.18},
                {"mid_out", "mid-grey output (fraction of the display maximum)", 0.01, 0.9, 0.267}},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), hdr_max = param(p, "hdr_max");
                 auto l = std::make_shared<detail::Lottes>(param(p, "contrast"), param(p, "shoulder"), hdr_max,
                                                           param(p, "mid_in"), param(p, "mid_out"));
                 return make(w, [=](double x) { return w * std::min(l->eval(std::min(x / w, hdr_max)), 1.0); },
                             LambdaCurve::Fn{}, std::vector<double>{w * hdr_max});
               }});
  v.push_back({"lottes-hdr", "Lottes' curve in display units: mid grey lands at mid_out paper whites, "
                             "hdr_max reaches the peak",
               "Lottes, GDC 2016 (HDR parameterisation)",
               {{"contrast", "a", 1.0, 3.0, 1.6},
                {"shoulder", "d", 0.5, 1.5, 0.977},
                {"hdr_max", "scene value that reaches the peak", 2.0, 1e5, 64.0},
                {"mid_in", "mid-grey input", 0.01, 1.0, 0.18},
                {"mid_out", "mid-grey output in paper-white units", 0.01, 1.0, 0.18}},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), hdr_max = param(p, "hdr_max");
                 const double mid_out = std::min(param(p, "mid_out") / w, 0.9);
                 auto l = std::make_shared<detail::Lottes>(param(p, "contrast"), param(p, "shoulder"), hdr_max,
                                                           param(p, "mid_in"), mid_out);
                 return make(w, [=](double x) { return w * std::min(l->eval(std::min(x, hdr_max)), 1.0); },
                             LambdaCurve::Fn{}, std::vector<double>{hdr_max});
               }});
  v.push_back({"aces-narkowicz", "Narkowicz's fit of the ACES RRT+ODT (SDR), stretched to the display maximum",
               "Narkowicz, ACES Filmic Tone Mapping Curve, 2015",
               {{"input_scale", "input multiplier (Narkowicz suggests 0.6 to match ACES exposure)", 0.01, 10.0, 1.0}},
               Apply::per_channel, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), s = param(p, "input_scale");
                 auto f = [](double x) { return (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14); };
                 auto finv = [](double y) {
                   const double a = 2.43 * y - 2.51, b = 0.59 * y - 0.03, c = 0.14 * y;
                   return (-b - std::sqrt(b * b - 4 * a * c)) / (2 * a);
                 };
                 // f reaches 1 (then clipped) where 0.08 u^2 - 0.56 u - 0.14 = 0.
                 const double qa = 2.51 - 2.43, qb = 0.03 - 0.59, qc = -0.14;
                 const double u1 = (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
                 return make(w, [=](double x) { return w * std::min(f(s * x / w), 1.0); },
                             [=](double y) { return finv(y / w) * w / s; }, std::vector<double>{u1 * w / s});
               }});
  v.push_back({"aces-narkowicz-hdr", "Narkowicz's HDR (1000 cd/m2) fit of ACES, normalised to the display maximum",
               "Narkowicz, HDR Display - First Steps, 2016 (a=15.8 b=2.12 c=1.2 d=5.92 e=1.9)",
               {{"input_scale", "input multiplier", 0.01, 10.0, 1.0}},
               Apply::per_channel, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double w = d.max_y(), s = param(p, "input_scale");
                 auto f = [](double x) { return (x * (15.8 * x + 2.12)) / (x * (1.2 * x + 5.92) + 1.9) / (15.8 / 1.2); };
                 return make(w, [=](double x) { return w * f(s * x); });
               }});
  v.push_back({"bt2390", "ITU-R BT.2390 EETF: Hermite roll-off in the PQ domain from a source range to the display",
               "ITU-R BT.2390-10 §5.4",
               {{"source_peak_nits", "mastering (source) peak", 100, 10000, 1000},
                {"source_black_nits", "mastering (source) black", 0, 1, 0},
                {"black_lift", "1: the report's black-level lift E3: the source black lands on the display black "
                               "(lifts black!); 0: no lift, light below the source black passes unchanged", 0, 1, 0}},
               Apply::max_rgb, true, true, true,
               [](const Display& d, const ParamValues& p) -> std::unique_ptr<Curve> {
                 const detail::Bt2390 e(param(p, "source_black_nits"), param(p, "source_peak_nits"), d.black_nits,
                                        d.peak_nits, param(p, "black_lift") >= 0.5);
                 return std::make_unique<Bt2390Curve>(e, d);
               }});
  // libplacebo's ST 2094-10-style knee (tonemap_curves.hpp pick_knee): the scene average
  // places it; sequences set source_peak_nits and source_avg_nits per frame (dynamic peak).
  const ParamSpec src_peak{"source_peak_nits", "mastering (source) peak; light above it is the source peak", 100, 10000,
                           1000};
  const ParamSpec src_avg{"source_avg_nits", "scene average light (0: unknown, the knee sits at knee_default of the "
                                             "source's PQ range)", 0, 10000, 0};
  const ParamSpec knee_adapt{"knee_adaptation", "0: the display knee is the source knee (as far as it fits); 1: "
                                                "the source knee's place in the source range, in the display's", 0, 1,
                             0.4};
  const ParamSpec knee_def{"knee_default", "knee as a fraction of the source's PQ range when the average is unknown",
                           0.1, 0.8, 0.4};
  v.push_back({"spline", "libplacebo's default: a single-pivot polynomial spline in the PQ domain, the pivot from "
                         "the scene average (ST 2094-10-style knee), quadratic below it and cubic above",
               "libplacebo src/tone_mapping.c (pl_tone_map_spline, PL_TONE_MAP_CONSTANTS)",
               {src_peak, src_avg, {"contrast", "slope at the pivot (d/s)^((1 - contrast) r) in PQ: 1 keeps the source's "
                                                "contrast there (slope 1), 0 the least, above 1 more", 0, 1.5, 0.5},
                knee_adapt, knee_def,
                {"slope_tuning", "how fast the slope follows the peak ratio", 0, 10, 1.5},
                {"slope_offset", "least exponent of the slope", 0, 1, 0.2}},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double pw = d.paper_white_nits, lw = param(p, "source_peak_nits");
                 auto c = std::make_shared<detail::Spline>(lw, param(p, "source_avg_nits"), d.peak_nits, knee_of(p),
                                                           param(p, "contrast"), param(p, "slope_tuning"),
                                                           param(p, "slope_offset"));
                 return make(d.max_y(), [c, pw](double x) { return c->map_nits(x * pw) / pw; }, LambdaCurve::Fn{},
                             std::vector<double>{lw / pw});
               }});
  v.push_back({"bt2446a", "ITU-R BT.2446 method A (HDR to SDR): the rho-based log curve on gamma-2.4 luma, its "
                          "three-piece tone curve and the SDR display's inverse; applied as a ratio (max-rgb) it keeps "
                          "chromaticity, which method A's chroma correction approximates in Y'CbCr",
               "ITU-R BT.2446-1 (03/2021) method A",
               {src_peak}, Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double pw = d.paper_white_nits;
                 auto c = std::make_shared<detail::Bt2446a>(param(p, "source_peak_nits"), d.peak_nits);
                 std::vector<double> kinks = c->kinks_nits();
                 for (double& k : kinks) k /= pw;
                 return make(d.max_y(), [c, pw](double x) { return c->map_nits(x * pw) / pw; }, LambdaCurve::Fn{},
                             std::move(kinks));
               }});
  v.push_back({"st2094-40", "SMPTE ST 2094-40 (HDR10+) basis OOTF without metadata: linear below a knee from the "
                            "scene average, an order-N Bezier above it with anchors derived from the target peak",
               "SMPTE ST 2094-40 Annex B; knee and anchors as libplacebo derives them (src/tone_mapping.c st2094_40)",
               {src_peak, src_avg, knee_adapt, knee_def},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double pw = d.paper_white_nits, lw = param(p, "source_peak_nits");
                 auto c = std::make_shared<detail::St2094_40>(lw, param(p, "source_avg_nits"), d.peak_nits, knee_of(p));
                 return make(d.max_y(), [c, pw](double x) { return c->map_nits(x * pw) / pw; }, LambdaCurve::Fn{},
                             std::vector<double>{c->kx * lw / pw, lw / pw});
               }});
  v.push_back({"st2094-10", "SMPTE ST 2094-10 (Dolby Vision) tone curve (c1 + c2 x) / (1 + c3 x) through the "
                            "source/display minimum, a knee from the scene average and the peaks",
               "SMPTE ST 2094-10 Annex B (n = 1, in linear light as libplacebo evaluates it, src/tone_mapping.c)",
               {src_peak, src_avg, knee_adapt, knee_def},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double pw = d.paper_white_nits, lw = param(p, "source_peak_nits");
                 auto c = std::make_shared<detail::St2094_10>(lw, param(p, "source_avg_nits"), d.peak_nits, knee_of(p));
                 return make(d.max_y(), [c, pw](double x) { return c->map_nits(x * pw) / pw; }, LambdaCurve::Fn{},
                             std::vector<double>{lw / pw});
               }});
  v.push_back({"mobius", "Mobius (mpv, libplacebo): linear up to a knee in units of the display peak, then a Mobius "
                         "transform that reaches the display peak at the source peak, C1 at the knee",
               "libplacebo src/tone_mapping.c (pl_tone_map_mobius); mpv vo_opengl",
               {src_peak, {"knee", "knee j as a fraction of the display peak (light below j x peak is kept)", 0, 0.99,
                           0.3}},
               Apply::max_rgb, true, true, false,
               [](const Display& d, const ParamValues& p) {
                 const double pw = d.paper_white_nits, lw = param(p, "source_peak_nits");
                 auto c = std::make_shared<detail::Mobius>(lw, d.peak_nits, param(p, "knee"));
                 return make(d.max_y(), [c, pw](double x) { return c->map_nits(x * pw) / pw; }, LambdaCurve::Fn{},
                             std::vector<double>{lw / pw});
               }});
  v.push_back({"pbr-neutral", "Khronos PBR Neutral: keeps base colours up to a start of compression, then "
                              "desaturates highlights",
               "Khronos PBR Neutral Tone Mapper, 2024 (start 0.76, desaturation 0.15)",
               {{"start", "start of compression", 0.1, 0.99, 0.76},
                {"desaturation", "highlight desaturation", 0.0, 1.0, 0.15}},
               Apply::rgb, false, false, false,
               [](const Display& d, const ParamValues& p) -> std::unique_ptr<Curve> {
                 return std::make_unique<PbrNeutral>(d.max_y(), param(p, "start"), param(p, "desaturation"));
               }});
  v.push_back({"agx", "AgX (Sobotka): log encoding, sigmoid, per-channel in an inset gamut",
               "AgX minimal polynomial fit (bwrensch 2023), as in three.js and Godot",
               {{"min_ev", "lowest encoded stop relative to mid grey", -20, -5, -12.47393},
                {"max_ev", "highest encoded stop relative to mid grey", 1, 10, 4.026069}},
               Apply::rgb, false, false, false,
               [](const Display& d, const ParamValues& p) -> std::unique_ptr<Curve> {
                 return std::make_unique<Agx>(d.max_y(), param(p, "min_ev"), param(p, "max_ev"));
               }});
  v.push_back({"ictcp", "Frostbite-style hue-preserving display mapper: PQ shoulder on ICtCp intensity, "
                        "desaturation toward white as intensity rolls off, optional hue shift",
               "Fry, HDR Color Grading and Display in Frostbite, GDC 2017; ICtCp per ITU-R BT.2100",
               {{"knee", "knee as a fraction of the PQ room between paper white and peak", 0.05, 1.0, 0.5},
                {"desaturation", "chroma scale = (I_out / I_in)^desaturation", 0.0, 8.0, 1.0},
                {"hue_shift", "0 keeps hue; 1 takes the per-channel result's hue", 0.0, 1.0, 0.0}},
               Apply::rgb, false, true, true,
               [](const Display& d, const ParamValues& p) -> std::unique_ptr<Curve> {
                 return std::make_unique<IctcpMapper>(d, param(p, "knee"), param(p, "desaturation"),
                                                      param(p, "hue_shift"));
               }});
  return v;
}

struct Registry {
  std::mutex mu;
  std::deque<ToneCurveInfo> list;  // deque: references stay valid as curves are added
  std::vector<ToneCurveInfo> snapshot;
  Registry() {
    for (auto& c : builtins()) list.push_back(std::move(c));
    snapshot.assign(list.begin(), list.end());
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

std::span<const ToneCurveInfo> curves() { return registry().snapshot; }

const ToneCurveInfo* find_curve(std::string_view name) {
  for (const auto& c : registry().list)
    if (c.name == name) return &c;
  return nullptr;
}

bool register_curve(ToneCurveInfo info) {
  auto& r = registry();
  std::lock_guard lock(r.mu);
  if (find_curve(info.name)) return false;
  r.list.push_back(std::move(info));
  r.snapshot.assign(r.list.begin(), r.list.end());
  return true;
}

Result<ParamValues> resolve_params(const ToneCurveInfo& info, const ParamValues& given) {
  ParamValues out;
  for (const auto& entry : given) {
    const std::string& name = entry.first;  // (clang 14 cannot capture structured bindings)
    const double value = entry.second;
    const auto it = std::find_if(info.params.begin(), info.params.end(),
                                 [&](const ParamSpec& s) { return s.name == name; });
    if (it == info.params.end()) {
      std::string known;
      for (const auto& s : info.params) known += (known.empty() ? "" : ", ") + std::string(s.name);
      return make_error("tonemap.param", fmt::format("tone curve '{}' has no parameter '{}' (parameters: {})",
                                                     info.name, name, known.empty() ? "none" : known),
                        "tone.params." + name);
    }
    if (!std::isfinite(value) || value < it->min || value > it->max)
      return make_error("tonemap.param", fmt::format("tone curve '{}' parameter '{}' = {} is outside [{}, {}]",
                                                     info.name, name, value, it->min, it->max),
                        "tone.params." + name);
    out[name] = value;
  }
  for (const auto& s : info.params) out.emplace(std::string(s.name), s.default_value);
  return out;
}

Result<std::unique_ptr<Curve>> prepare(std::string_view name, const Display& display, const ParamValues& params) {
  const ToneCurveInfo* info = find_curve(name);
  if (!info) {
    std::string known;
    for (const auto& c : curves()) known += (known.empty() ? "" : ", ") + std::string(c.name);
    return make_error("tonemap.unknown", fmt::format("unknown tone curve '{}' (known: {})", name, known), "tone.curve");
  }
  auto resolved = resolve_params(*info, params);
  if (!resolved) return resolved.error();
  return info->prepare(display, *resolved);
}

namespace {
// Where the parabolas through (x[i], y[i]) for i in `l` and in `r` meet between lo and hi
// (Lagrange form, solved as a quadratic), or NaN.
double meet(const std::vector<double>& x, const std::vector<double>& y, std::array<std::size_t, 3> l,
            std::array<std::size_t, 3> r, double lo, double hi) {
  // Each parabola as c0 + c1 t + c2 t^2 in t = x - lo (well conditioned near the kink).
  auto fit = [&](std::array<std::size_t, 3> i) {
    const double t0 = x[i[0]] - lo, t1 = x[i[1]] - lo, t2 = x[i[2]] - lo;
    const double d01 = (y[i[1]] - y[i[0]]) / (t1 - t0), d12 = (y[i[2]] - y[i[1]]) / (t2 - t1);
    const double c2 = (d12 - d01) / (t2 - t0), c1 = d01 - c2 * (t0 + t1), c0 = y[i[0]] - c1 * t0 - c2 * t0 * t0;
    return std::array<double, 3>{c0, c1, c2};
  };
  const auto a = fit(l), b = fit(r);
  const double q2 = a[2] - b[2], q1 = a[1] - b[1], q0 = a[0] - b[0], span = hi - lo;
  auto inside = [&](double t) { return t >= 0 && t <= span; };
  if (std::abs(q2) * span < 1e-12 * std::abs(q1)) {
    const double t = -q0 / q1;
    return q1 != 0 && inside(t) ? lo + t : std::nan("");
  }
  const double disc = q1 * q1 - 4 * q2 * q0;
  if (disc < 0) return std::nan("");
  const double sq = std::sqrt(disc), t1 = (-q1 + sq) / (2 * q2), t2 = (-q1 - sq) / (2 * q2);
  if (inside(t1) && (!inside(t2) || std::abs(t1 - 0.5 * span) < std::abs(t2 - 0.5 * span))) return lo + t1;
  return inside(t2) ? lo + t2 : std::nan("");
}
}  // namespace

std::vector<double> find_kinks(const std::function<double(double)>& f, double lo, double hi) {
  constexpr int kPerOctave = 1024;
  const int n = static_cast<int>(std::ceil(std::log2(hi / lo) * kPerOctave));
  std::vector<double> x(static_cast<std::size_t>(n) + 1), y(x.size()), slope(static_cast<std::size_t>(n));
  for (int i = 0; i <= n; ++i) {
    x[static_cast<std::size_t>(i)] = lo * std::exp2(static_cast<double>(i) / kPerOctave);
    y[static_cast<std::size_t>(i)] = f(x[static_cast<std::size_t>(i)]);
  }
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    slope[u] = (y[u + 1] - y[u]) / (x[u + 1] - x[u]);
  }
  // d(i) = |slope[i + 1] - slope[i]|: a kink inside interval k shows in d(k - 1) and d(k), so
  // the first j whose max(d(j - 1), d(j)) stands out is k - 1 or k; samples j - 2 .. j lie left
  // of the kink and j + 2 .. j + 4 right of it.
  auto d = [&](int i) { return std::abs(slope[static_cast<std::size_t>(i + 1)] - slope[static_cast<std::size_t>(i)]); };
  std::vector<double> kinks;
  for (int j = 4; j + 5 < n; ++j) {
    const auto u = static_cast<std::size_t>(j);
    const double here = std::max(d(j - 1), d(j));
    const double around = std::max(d(j - 3), d(j + 2));
    // A jump that moves the function by at least 1e-6 of its value over one unit of x:
    // smaller ones cannot move a table lookup by a 16-bit step (nor can a curve that has
    // saturated to its maximum in the last bits of a double).
    if (!(here > 50 * around && here * x[u] > 1e-6 * std::abs(y[u]))) continue;
    const double xk = meet(x, y, {u - 2, u - 1, u}, {u + 2, u + 3, u + 4}, x[u - 1], x[u + 2]);
    const double at = std::isnan(xk) ? 0.5 * (x[u] + x[u + 1]) : xk;
    if (kinks.empty() || at > kinks.back() * (1 + 1e-6)) kinks.push_back(at);
    j += 4;
  }
  return kinks;
}

std::string_view default_curve(Mode) { return "pq-shoulder"; }

}  // namespace hdrd::tonemap

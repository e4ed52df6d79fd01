#include "encode/colour/gamut_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "encode/colour/transfer.hpp"

namespace hdrd {

using color::Mat3;
using color::Vec3;

namespace {
constexpr const auto& kNames = kGamutMappingNames;
constexpr double kPi = 3.14159265358979323846;
}  // namespace

std::string_view to_string(GamutMapping g) { return kNames[static_cast<std::size_t>(g)]; }

std::optional<GamutMapping> parse_gamut_mapping(std::string_view s) {
  if (s == "desaturate") return GamutMapping::ictcp;
  for (std::size_t i = 0; i + 1 < kNames.size(); ++i)
    if (kNames[i] == s) return static_cast<GamutMapping>(i);
  return std::nullopt;
}

namespace gamut {

bool in_cube(Vec3 c, double peak, double tol) {
  const double lo = -tol * peak, hi = peak * (1 + tol);
  return c.x >= lo && c.y >= lo && c.z >= lo && c.x <= hi && c.y <= hi && c.z <= hi;
}
Vec3 clamp_to(Vec3 c, double peak) {
  return {std::clamp(c.x, 0.0, peak), std::clamp(c.y, 0.0, peak), std::clamp(c.z, 0.0, peak)};
}

namespace {
Vec3 positive(Vec3 v) { return {std::max(v.x, 0.0), std::max(v.y, 0.0), std::max(v.z, 0.0)}; }
}  // namespace

namespace {
// Constant intensity i (capped at the peak's) and hue: the largest chroma scale of (ct, cp)
// up to 1 that fits [0, peak]^3 through to_c.
Vec3 fit_chroma(double i, double ct, double cp, const Mat3& to_c, double peak) {
  i = std::min(i, transfer::pq_inverse_eotf(peak));
  auto at = [&](double s) { return to_c * color::ictcp_to_rec2020_nits({i, ct * s, cp * s}); };
  double lo = 0, hi = 1;
  if (in_cube(at(1.0), peak, 1e-6)) return clamp_to(at(1.0), peak);
  for (int it = 0; it < 24; ++it) {
    const double mid = 0.5 * (lo + hi);
    (in_cube(at(mid), peak, 1e-6) ? lo : hi) = mid;
  }
  return clamp_to(at(lo), peak);
}
}  // namespace

Vec3 desaturate(Vec3 working_nits, const Mat3& to_c, double peak) {
  const Vec3 ictcp = color::rec2020_nits_to_ictcp(positive(working_nits));
  return fit_chroma(ictcp.x, ictcp.y, ictcp.z, to_c, peak);
}

Mapper::Mapper(GamutMapping g, const Mat3& source_to_working, const color::Primaries& target, double peak_nits,
               double tolerance, std::optional<color::Primaries> container)
    : g_(g), peak_(peak_nits), tol_(tolerance), i_peak_(transfer::pq_inverse_eotf(peak_nits)) {
  if (container)
    to_container_ = g == GamutMapping::absolute ? color::xyz_to_rgb(*container) * color::rgb_to_xyz(target)
                                                : color::rgb_to_rgb(target, *container);
  w2t_ = g == GamutMapping::absolute ? color::xyz_to_rgb(target) * color::rgb_to_xyz(color::kRec2020)
                                     : color::rgb_to_rgb(color::kRec2020, target);
  t2w_ = color::inverse(w2t_);
  w2s_ = color::inverse(source_to_working);
  // The source fits when each of its primaries does (then its whole cube does: each target
  // channel is a sum of the primaries' non-negative parts, the white's being 1).
  bool source_fits = true;
  for (int k = 0; k < 3; ++k) {
    const Vec3 primary{source_to_working.m[0][k], source_to_working.m[1][k], source_to_working.m[2][k]};
    const Vec3 t = color::rgb_to_rgb(color::kRec2020, target) * primary;
    if (std::min({t.x, t.y, t.z}) < -1e-6) source_fits = false;
  }
  const bool global = g == GamutMapping::perceptual || g == GamutMapping::saturation ||
                      g == GamutMapping::linear || g == GamutMapping::darken;
  local_ = !global;
  keeps_inside_ = (!global || source_fits) && !container;
  source_fits_ = source_fits;
  if (g == GamutMapping::darken && !source_fits) {
    // The source's primaries and secondaries at the peak, in the target: the largest channel.
    const Vec3 corners[6] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}, {1, 1, 0}};
    for (const Vec3& c : corners) {
      const Vec3 t = w2t_ * (source_to_working * c);
      light_gain_ = std::min(light_gain_, 1.0 / std::max({t.x, t.y, t.z}));
    }
  }
}

void Mapper::build_tables() const {
  std::call_once(tables_once_, [&] {
    const bool global = g_ == GamutMapping::perceptual || g_ == GamutMapping::saturation ||
                        g_ == GamutMapping::linear || g_ == GamutMapping::darken;
    const Mat3 w2s_cube = w2s_;
    target_c_.resize(kI * kH);
    cusp_i_.resize(kH);
    if (global) source_c_.resize(kI * kH);
    for (int hi = 0; hi < kH; ++hi) {
      const double h = -kPi + 2 * kPi * hi / kH;
      double best = -1, best_i = 0.5 * i_peak_;
      for (int ii = 0; ii < kI; ++ii) {
        const double i = i_peak_ * ii / (kI - 1);
        const double ct = boundary(w2t_, i, h);
        target_c_[static_cast<std::size_t>(hi * kI + ii)] = static_cast<float>(ct);
        if (ct > best) best = ct, best_i = i;
        if (global) source_c_[static_cast<std::size_t>(hi * kI + ii)] = static_cast<float>(boundary(w2s_cube, i, h));
      }
      cusp_i_[static_cast<std::size_t>(hi)] = static_cast<float>(best_i);
    }
    if (g_ == GamutMapping::linear && !source_fits_) {
      // libplacebo's linear: the least ratio of the cusps' chroma over the hues.
      for (int hi = 0; hi < kH; ++hi) {
        double ct = 0, cs = 0;
        for (int ii = 0; ii < kI; ++ii) {
          ct = std::max(ct, static_cast<double>(target_c_[static_cast<std::size_t>(hi * kI + ii)]));
          cs = std::max(cs, static_cast<double>(source_c_[static_cast<std::size_t>(hi * kI + ii)]));
        }
        if (cs > 0) chroma_gain_ = std::min(chroma_gain_, ct / cs);
      }
    }
  });
}

bool Mapper::inside(const Mat3& to_rgb, Vec3 working) const { return in_cube(to_rgb * working, peak_, 1e-6); }

Vec3 Mapper::at(double i, double c, double h) const {
  return color::ictcp_to_rec2020_nits({i, c * std::cos(h), c * std::sin(h)});
}

double Mapper::boundary(const Mat3& to_rgb, double i, double h) const {
  if (!(i > 0) || i >= i_peak_) return 0.0;
  double lo = 0, hi = 0.03;
  while (inside(to_rgb, at(i, hi, h))) {
    lo = hi;
    hi *= 2;
    if (hi > 4) return hi;
  }
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (inside(to_rgb, at(i, mid, h)) ? lo : hi) = mid;
  }
  return lo;
}

double Mapper::table(const std::vector<float>& t, double i, double h) const {
  const double fi = std::clamp(i / i_peak_, 0.0, 1.0) * (kI - 1);
  const double fh = (h + kPi) / (2 * kPi) * kH;
  const int i0 = std::min(static_cast<int>(fi), kI - 2);
  const int h0 = static_cast<int>(std::floor(fh));
  const double ui = fi - i0, uh = fh - h0;
  auto v = [&](int hh, int ii) {
    hh = ((hh % kH) + kH) % kH;
    return static_cast<double>(t[static_cast<std::size_t>(hh * kI + ii)]);
  };
  return (1 - uh) * ((1 - ui) * v(h0, i0) + ui * v(h0, i0 + 1)) + uh * ((1 - ui) * v(h0 + 1, i0) + ui * v(h0 + 1, i0 + 1));
}

double Mapper::cusp_intensity(double h) const {
  const double fh = (h + kPi) / (2 * kPi) * kH;
  const int h0 = static_cast<int>(std::floor(fh));
  const double u = fh - h0;
  auto v = [&](int hh) { return static_cast<double>(cusp_i_[static_cast<std::size_t>(((hh % kH) + kH) % kH)]); };
  return (1 - u) * v(h0) + u * v(h0 + 1);
}

Vec3 Mapper::clip_toward(Lch c, double ti) const {
  // The grey at ti fits (ti <= the peak's intensity), so s = 0 always does.
  auto p = [&](double s) { return at(ti + s * (c.i - ti), s * c.c, c.h); };
  if (inside(w2t_, p(1.0))) return p(1.0);
  double lo = 0, hi = 1;
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (inside(w2t_, p(mid)) ? lo : hi) = mid;
  }
  return p(lo);
}

Vec3 Mapper::finish(Vec3 working) const { return clamp_to(w2t_ * working, peak_); }

Vec3 Mapper::map(Vec3 working_nits) const {
  const Vec3 t = map_to_target(working_nits);
  return to_container_ ? *to_container_ * t : t;
}

Vec3 Mapper::map_to_target(Vec3 working_nits) const {
  const Vec3 direct = w2t_ * working_nits;
  const bool fits = in_cube(direct, peak_, tol_);
  if (g_ == GamutMapping::clip) return clamp_to(direct, peak_);
  if (fits && (keeps_inside_ || local_)) return clamp_to(direct, peak_);
  if (g_ == GamutMapping::ictcp) return desaturate(working_nits, w2t_, peak_);
  build_tables();
  const Vec3 ictcp = color::rec2020_nits_to_ictcp(positive(working_nits));
  Lch c{std::min(ictcp.x, i_peak_), std::hypot(ictcp.y, ictcp.z), std::atan2(ictcp.z, ictcp.y)};
  if (!(c.i > 0)) return {};
  switch (g_) {
    case GamutMapping::relative:
    case GamutMapping::absolute:
      return finish(clip_toward(c, std::min(cusp_intensity(c.h), i_peak_)));
    case GamutMapping::highlight: {
      const double i = std::min(c.i + 0.1, i_peak_);
      return fit_chroma(i, 1.2 * c.c * std::cos(c.h + kPi), 1.2 * c.c * std::sin(c.h + kPi), w2t_, peak_);
    }
    case GamutMapping::darken: {
      const Vec3 d = color::rec2020_nits_to_ictcp(positive(working_nits) * light_gain_);
      const Lch dc{std::min(d.x, i_peak_), std::hypot(d.y, d.z), c.h};  // the hue as it was
      return finish(clip_toward(dc, std::min(cusp_intensity(c.h), i_peak_)));
    }
    case GamutMapping::perceptual: {
      const double ct = table(target_c_, c.i, c.h), cs = table(source_c_, c.i, c.h), k = 0.7 * ct;
      if (cs > ct && c.c > k) {
        const double x = c.c - k, a = ct - k, b = cs - k;
        c.c = k + x / (1 + x * (1 / a - 1 / b));
      }
      break;
    }
    case GamutMapping::saturation: {
      const double ct = table(target_c_, c.i, c.h), cs = table(source_c_, c.i, c.h);
      if (cs > ct && cs > 0) c.c *= ct / cs;
      break;
    }
    case GamutMapping::linear:
      c.c *= chroma_gain_;
      break;
    default:
      break;
  }
  // What the tables' interpolation (or a colour beyond the source gamut) leaves outside is
  // fitted at constant intensity and hue.
  return fit_chroma(c.i, c.c * std::cos(c.h), c.c * std::sin(c.h), w2t_, peak_);
}

}  // namespace gamut
}  // namespace hdrd

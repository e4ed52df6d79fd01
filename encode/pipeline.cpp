// The encode pipeline: preparation (validation, metering, curve), the double-precision
// reference path, and the frame encoder that runs the staged fast path over rows.
#include "encode/pipeline.hpp"

#include "encode/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <bit>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "encode/kernel/light_kernels.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd {

using color::Mat3;
using color::Vec3;

std::string_view to_string(InputUnits u) { return u == InputUnits::relative ? "relative" : "absolute"; }
std::optional<InputUnits> parse_input_units(std::string_view s) {
  if (s == "relative") return InputUnits::relative;
  if (s == "absolute") return InputUnits::absolute;
  return std::nullopt;
}

namespace detail {

// NaN/Inf rule (documented in docs/encoding.md): NaN -> 0; +-Inf and magnitudes above
// 1e30 -> +-1e30, which the tone curve rolls off to the peak. Codes never see a NaN.
constexpr double kMaxSceneMagnitude = 1e30;
Vec3 sanitize(Vec3 v) {
  auto s = [](double x) { return std::isnan(x) ? 0.0 : std::clamp(x, -kMaxSceneMagnitude, kMaxSceneMagnitude); };
  return {s(v.x), s(v.y), s(v.z)};
}

Mat3 working_to_container(const DisplayTarget& t) {
  return t.container() == color::kRec2020 ? Mat3::identity() : color::rgb_to_rgb(color::kRec2020, t.container());
}

using gamut::clamp_to;
using gamut::in_cube;

// scRGB is not mapped: its negatives carry wide colours. The family's other maps
// (gamut_map.hpp) run through their prepared mapper; HLG's volume then fits at constant
// luminance as ictcp does.
Vec3 gamut_map(Vec3 working_nits, const DisplayTarget& t, GamutMapping g, const gamut::Mapper* mapper) {
  const Mat3 to_c = working_to_container(t);
  const Vec3 c = to_c * working_nits;
  if (t.mode == Mode::scrgb) return c;
  const double peak = t.peak_nits;
  if (mapper)
    return fit_volume(mapper->map(working_nits), t, g == GamutMapping::clip ? GamutMapping::clip : GamutMapping::ictcp);
  if (in_cube(c, peak, kGamutTolerance) || g == GamutMapping::clip) return fit_volume(c, t, g);
  return fit_volume(gamut::desaturate(working_nits, to_c, peak), t, g);
}

bool maps_every_pixel(const PreparedPipeline& p) { return p.gamut_mapper && !p.gamut_mapper->keeps_inside(); }

namespace {
// The input's gamut in the working space: its primaries, or the working space itself where
// they reach beyond it (XYZ, ACES AP0: light outside Rec.2020 is clamped before the curve).
Mat3 source_gamut(const Mat3& input_to_working) {
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      if (input_to_working.m[r][k] < -1e-6) return Mat3::identity();
  return input_to_working;
}
}  // namespace

std::optional<color::Primaries> display_gamut(const DisplayTarget& t) {
  if (!t.display_primaries || t.mode == Mode::scrgb) return std::nullopt;
  const Mat3 to_c = color::rgb_to_rgb(*t.display_primaries, t.container());
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      if (to_c.m[r][k] < -1e-6) return std::nullopt;
  return t.display_primaries;
}

std::shared_ptr<const gamut::Mapper> cached_gamut_mapper(GamutMapping g, const Mat3& input_to_working,
                                                         const DisplayTarget& t, bool to_display) {
  const std::optional<color::Primaries> display = to_display ? display_gamut(t) : std::nullopt;
  if ((g == GamutMapping::ictcp || g == GamutMapping::clip) && !display) return nullptr;
  if (t.mode == Mode::scrgb) return nullptr;
  static std::mutex mu;
  static std::vector<std::pair<std::string, std::shared_ptr<const gamut::Mapper>>> cache;
  const Mat3 src = source_gamut(input_to_working);
  std::string key = fmt::format("{}|{:.17g}|{}", static_cast<int>(g), t.peak_nits, t.container().red.x);
  if (display)
    for (const auto& c : {display->red, display->green, display->blue, display->white})
      key += fmt::format("|d{:.17g},{:.17g}", c.x, c.y);
  for (const auto& row : src.m)
    for (double v : row) key += fmt::format("|{:.17g}", v);
  {
    std::lock_guard lock(mu);
    for (const auto& [k, v] : cache)
      if (k == key) return v;
  }
  auto m = display ? std::make_shared<const gamut::Mapper>(g, src, *display, t.peak_nits, kGamutTolerance, t.container())
                   : std::make_shared<const gamut::Mapper>(g, src, t.container(), t.peak_nits, kGamutTolerance);
  std::lock_guard lock(mu);
  if (cache.size() >= 8) cache.erase(cache.begin());
  cache.emplace_back(key, m);
  return m;
}

// HLG: inside the cube, E = k(Y_D) F_D with a scale k of the luminance alone
// (HlgDisplay::ootf_inverse_scale), so along the line from F_D to the grey of the same
// luminance, c(s) = Y_D + s (F_D - Y_D), k stays fixed and the largest s with every
// k c(s) <= 1 is closed-form: s = min over the channels above Y_D of (1/k - Y_D) / (F_D - Y_D).
// That keeps the luminance and the dominant wavelength and gives up saturation (the
// REFERENCE.md §1.5 direction: toward the achromatic axis); 1/k >= Y_D for every Y_D <= peak,
// so the grey always fits. `clip` clips E per channel instead, which is what a display
// shows for a signal clipped at 1: hue and luminance change, and the dump says so.
Vec3 fit_volume(Vec3 c, const DisplayTarget& t, GamutMapping g) {
  if (t.mode == Mode::scrgb) return c;
  c = clamp_to(c, t.peak_nits);
  if (t.mode != Mode::hlg) return c;
  const auto hd = transfer::HlgDisplay::from_levels(t.peak_nits, t.black_nits);
  const double yd = color::dot(color::kRec2020Luma, c);
  const double k = hd.ootf_inverse_scale(yd);
  if (std::max({c.x, c.y, c.z}) * k <= 1.0 + kGamutTolerance) return c;
  if (g == GamutMapping::clip)
    return hd.ootf({std::min(c.x * k, 1.0), std::min(c.y * k, 1.0), std::min(c.z * k, 1.0)});
  double s = 1.0;
  for (double v : {c.x, c.y, c.z})
    if (v > yd) s = std::min(s, (1.0 / k - yd) / (v - yd));
  s = std::max(s, 0.0);
  return {yd + s * (c.x - yd), yd + s * (c.y - yd), yd + s * (c.z - yd)};
}

bool has_black_floor(const DisplayTarget& t) {
  return t.black_nits > 0 && (t.mode == Mode::sdr_bt1886 || t.mode == Mode::hlg);
}

Vec3 displayed_light(Vec3 c, const DisplayTarget& t) {
  if (!has_black_floor(t)) return c;
  if (t.mode == Mode::sdr_bt1886) {
    // BT.1886: V = 0 decodes to Lb, and no code decodes below it.
    const double b = t.black_nits;
    return {std::max(c.x, b), std::max(c.y, b), std::max(c.z, b)};
  }
  // HLG: E' = 0 decodes to the scene light OETF^-1(beta) in that channel (BT.2100 Table 5).
  const auto hd = transfer::HlgDisplay::from_levels(t.peak_nits, t.black_nits);
  const double eb = hd.scene_black();
  const Vec3 e = hd.inverse_ootf(c);
  if (e.x >= eb && e.y >= eb && e.z >= eb) return c;
  return hd.ootf({std::max(e.x, eb), std::max(e.y, eb), std::max(e.z, eb)});
}

namespace {
// f as a ToneStage table with a toe: the table on [2^min_exp2, 2^max_exp2] with a node on each
// kink, f(0), and the toe's slope from f(0) to the table's bottom.
FloatBitsLut toe_table(const std::function<double(double)>& f, int min_exp2, int max_exp2,
                       const std::vector<double>& kinks, float& zero, float& slope) {
  FloatBitsLut l(f, min_exp2, max_exp2, kinks);
  zero = static_cast<float>(f(0.0));
  slope = static_cast<float>((f(static_cast<double>(l.lo())) - f(0.0)) / l.lo());
  return l;
}

std::vector<double> scaled(std::vector<double> v, double by) {
  for (double& x : v) x *= by;
  return v;
}
}  // namespace

ToneStage build_tone_stage(const PreparedPipeline& p) {
  ToneStage s;
  const auto& t = p.settings.target;
  s.paper_white = static_cast<float>(t.paper_white_nits);
  s.peak = static_cast<float>(t.peak_nits);
  if (p.settings.grade && p.settings.grade->placement() == grade::Placement::baked) {
    s.kind = ToneKind::none;
    return s;
  }
  const std::shared_ptr<const tonemap::Curve> curve = p.curve;
  const double pw = t.paper_white_nits;
  if (p.curve_info->name == "clip" && p.apply == tonemap::Apply::per_channel) {
    s.kind = ToneKind::clip;
  } else if (p.apply == tonemap::Apply::per_channel) {
    s.kind = ToneKind::per_channel;
    const auto f = [=](double x) { return curve->map(x) * pw; };
    s.lut = toe_table(f, -20, 20, curve->kinks(), s.zero_nits, s.toe_slope);
  } else if (p.apply == tonemap::Apply::max_rgb || p.apply == tonemap::Apply::luminance) {
    s.kind = ToneKind::ratio;
    s.ratio_of_luminance = p.apply == tonemap::Apply::luminance;
    s.lut = FloatBitsLut([=](double m) { return curve->shape(m) * pw / m; }, -20, 20, curve->kinks());
    if (curve->lifts_black()) {
      // Per channel on the ratio's nits, down to 2^-40 cd/m2 (where the toe's straight line
      // is 0.06 of a 16-bit PQ step off the lift, which rises as PQ does near 0).
      const auto lift = [=](double n) { return curve->lift(n / pw) * pw; };
      s.has_lift = true;
      s.lift = toe_table(lift, -40, 14, scaled(curve->lift_kinks(), pw), s.lift_zero_nits, s.lift_toe_slope);
    }
  } else {
    s.kind = ToneKind::reference;
  }
  return s;
}

namespace {
// SignalStage::code_nits_poly from code_to_nits (normal equations of a degree-4 fit on
// the 32 codes of each segment; x in [0, 1) keeps them well conditioned).
void fit_code_light(SignalStage& s) {
  constexpr int kDegree = 4, kSegment = 32;
  const int segments = static_cast<int>(s.code_to_nits.size()) / kSegment;
  s.code_nits_poly.assign(static_cast<std::size_t>((kDegree + 1) * segments), 0.0f);
  s.code_nits_poly_error = 0;
  for (int seg = 0; seg < segments; ++seg) {
    double a[kDegree + 1][kDegree + 2] = {};
    for (int t = 0; t < kSegment; ++t) {
      const double x = t / static_cast<double>(kSegment), y = s.code_to_nits[static_cast<std::size_t>(seg * kSegment + t)];
      double p[kDegree + 1] = {1};
      for (int i = 1; i <= kDegree; ++i) p[i] = p[i - 1] * x;
      for (int i = 0; i <= kDegree; ++i) {
        for (int j = 0; j <= kDegree; ++j) a[i][j] += p[i] * p[j];
        a[i][kDegree + 1] += p[i] * y;
      }
    }
    for (int i = 0; i <= kDegree; ++i) {  // Gauss-Jordan with partial pivoting
      int pivot = i;
      for (int r = i + 1; r <= kDegree; ++r)
        if (std::abs(a[r][i]) > std::abs(a[pivot][i])) pivot = r;
      std::swap(a[i], a[pivot]);
      for (int r = 0; r <= kDegree; ++r)
        if (r != i) {
          const double f = a[r][i] / a[i][i];
          for (int c = i; c <= kDegree + 1; ++c) a[r][c] -= f * a[i][c];
        }
    }
    // Fitted in t / 32, stored for t.
    for (int i = 0; i <= kDegree; ++i)
      s.code_nits_poly[static_cast<std::size_t>(i * segments + seg)] =
          static_cast<float>(a[i][kDegree + 1] / a[i][i] / std::pow(kSegment, i));
    for (int t = 0; t < kSegment; ++t) {
      const float x = static_cast<float>(t);
      float v = s.code_nits_poly[static_cast<std::size_t>(kDegree * segments + seg)];
      for (int i = kDegree - 1; i >= 0; --i) v = std::fma(v, x, s.code_nits_poly[static_cast<std::size_t>(i * segments + seg)]);
      s.code_nits_poly_error = std::max(
          s.code_nits_poly_error, std::abs(static_cast<double>(v) - s.code_to_nits[static_cast<std::size_t>(seg * kSegment + t)]));
    }
  }
}
}  // namespace

namespace {
// The bottom octave of a signal table: low enough that the signal there rounds to the same
// 16-bit PNG sample as the signal of 0 (the table's value below its range is its bottom
// value), so black is exactly black's sample in every transfer (BT.1886 with Lb = 0 wrote
// 30 and gamma 2.2 wrote 15 from a bottom at 2^-20 cd/m2).
int signal_bottom_exp2(const std::function<double(double)>& f, int from) {
  auto sample = [&](double v) { return std::lround(std::clamp(f(v), 0.0, 1.0) * 65535.0); };
  const long zero = sample(0.0);
  int e = from;
  while (e > -120 && sample(std::ldexp(1.0, e)) != zero) --e;
  return e;
}
}  // namespace

namespace {
// The largest code in [0, top] whose decoded light is at most the peak (decoded rises with
// the code); 0 when even code 0 is above it.
template <class Decode>
int peak_code_at_most(const Decode& decoded, int top, double peak_nits) {
  int lo = 0, hi = top;  // invariant: the answer is in [lo, hi]
  if (decoded(top) <= peak_nits) return top;
  while (lo < hi) {
    const int mid = lo + (hi - lo + 1) / 2;
    if (decoded(mid) <= peak_nits) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}
}  // namespace

PeakCodes peak_codes(const DisplayTarget& t) {
  const int bits = t.mode == Mode::scrgb ? 16 : t.bits;
  PeakCodes p{(1 << std::min(bits, 16)) - 1, 65535};
  if (t.mode != Mode::hdr10) return p;  // the other transfers' top signal is the peak
  const auto decoded = [&](int c) {
    return transfer::pq_eotf(t.range == Range::narrow ? std::clamp(transfer::dequantize_narrow(c, bits), 0.0, 1.0)
                                                      : transfer::dequantize_full(c, bits));
  };
  p.code = peak_code_at_most(decoded, p.code, t.peak_nits);
  if (t.range == Range::full)
    p.signal16 = peak_code_at_most([](int k) { return transfer::pq_eotf(k / 65535.0); }, 65535, t.peak_nits);
  return p;
}

SignalStage build_signal_stage(const DisplayTarget& t) {
  SignalStage s;
  s.mode = t.mode;
  const int bits = t.mode == Mode::scrgb ? 16 : t.bits;
  s.max_code = (1 << std::min(bits, 16)) - 1;
  if (t.range == Range::narrow) {
    s.code_scale = static_cast<float>(219.0 * std::ldexp(1.0, bits - 8));
    s.code_offset = static_cast<float>(16.0 * std::ldexp(1.0, bits - 8));
  } else {
    s.code_scale = static_cast<float>(s.max_code);
    s.code_offset = 0;
  }
  const double peak = t.peak_nits;
  std::function<double(double)> f;
  std::vector<double> kinks;  // where f's slope jumps (float_lut.hpp)
  int min_exp2 = -20, max_exp2 = 14;
  switch (t.mode) {
    case Mode::hdr10:
      // Down to 2^-30 cd/m2, where PQ rounds to 0 even as a 16-bit PNG sample.
      f = [](double n) { return transfer::pq_inverse_eotf(n); };
      min_exp2 = -30;
      break;
    case Mode::sdr:
      if (t.sdr_curve == SdrCurve::srgb) {
        f = [=](double n) { return transfer::srgb_inverse_eotf(std::min(n / peak, 1.0)); };
        kinks.push_back(0.0031308 * peak);  // IEC 61966-2-1: the linear toe meets the power (C0 only)
      } else {
        f = [=](double n) { return transfer::gamma22_inverse_eotf(std::min(n / peak, 1.0)); };
      }
      kinks.push_back(peak);
      break;
    case Mode::sdr_bt1886: {
      const auto b = transfer::Bt1886::from_levels(peak, t.black_nits);
      f = [=](double n) { return b.inverse_eotf(n); };
      kinks = {t.black_nits, peak};  // V clipped to [0, 1]
      break;
    }
    case Mode::hlg:
      s.hlg = transfer::HlgDisplay::from_levels(peak, t.black_nits);
      s.hlg_peak = static_cast<float>(peak);
      s.hlg_gamma = static_cast<float>(s.hlg.gamma);
      f = [hd = s.hlg](double e) { return hd.signal_of_scene(e); };
      kinks = {1.0, s.hlg.scene_black()};  // E clipped at 1; no signal below the lifted black
      min_exp2 = -30, max_exp2 = 1;
      break;
    case Mode::scrgb:
      break;
  }
  if (f) s.signal = FloatBitsLut(f, signal_bottom_exp2(f, min_exp2), max_exp2, kinks);
  const PeakCodes top = peak_codes(t);
  s.peak_code = top.code;
  s.signal_max = top.signal16 / 65535.0f;
  if (f && t.mode != Mode::hlg) {
    const double scale = t.range == Range::narrow ? 219.0 * std::ldexp(1.0, bits - 8) : s.max_code;
    const double offset = t.range == Range::narrow ? 16.0 * std::ldexp(1.0, bits - 8) : 0.0;
    const int max_code = s.peak_code;
    s.codes = FloatBitsQuantizer(
        [&](double nits) {
          const double v = std::floor(std::clamp(f(nits), 0.0, 1.0) * scale + offset + 0.5);
          return std::min(static_cast<int>(v), max_code);
        },
        min_exp2, max_exp2);
  }
  if (t.mode == Mode::hdr10 || t.mode == Mode::hlg) {
    s.code_to_nits.resize(static_cast<std::size_t>(s.max_code) + 1);
    for (int c = 0; c <= s.max_code; ++c) {
      const double e = t.range == Range::narrow ? std::clamp(transfer::dequantize_narrow(c, bits), 0.0, 1.0)
                                                : transfer::dequantize_full(c, bits);
      // HLG: the scene light E the display decodes (black lift included); the OOTF is
      // applied per pixel.
      s.code_to_nits[static_cast<std::size_t>(c)] =
          static_cast<float>(t.mode == Mode::hdr10 ? transfer::pq_eotf(e) : s.hlg.scene_of_signal(e));
    }
  }
  if (t.mode == Mode::hdr10 && s.max_code == 1023) {
    fit_code_light(s);
    // Narrow range clamps below code 64 and above 940: a kink inside a segment no quartic
    // follows, so such a table stays a table.
    if (s.code_nits_poly_error > kCodeLightFitTolerance) s.code_nits_poly.clear();
  }
  return s;
}

namespace {
template <class T>
class StageCache {
 public:
  template <class Build>
  std::shared_ptr<const T> get(const std::string& key, Build build) {
    {
      std::lock_guard lock(mu_);
      for (const auto& [k, v] : entries_)
        if (k == key) return v;
    }
    auto value = std::make_shared<const T>(build());
    std::lock_guard lock(mu_);
    if (entries_.size() >= kCapacity) entries_.erase(entries_.begin());
    entries_.emplace_back(key, value);
    return value;
  }

 private:
  static constexpr std::size_t kCapacity = 16;
  std::mutex mu_;
  std::vector<std::pair<std::string, std::shared_ptr<const T>>> entries_;
};
}  // namespace

std::shared_ptr<const ToneStage> cached_tone_stage(const PreparedPipeline& p) {
  static StageCache<ToneStage> cache;
  const auto& t = p.settings.target;
  std::string key = fmt::format("{}|{}|{:.17g}|{:.17g}|{:.17g}|{}|{}", p.curve_info->name, tonemap::to_string(p.apply),
                                t.peak_nits, t.black_nits, t.paper_white_nits, static_cast<int>(t.mode),
                                p.settings.grade && p.settings.grade->placement() == grade::Placement::baked);
  for (const auto& [k, v] : p.params) key += fmt::format("|{}={:.17g}", k, v);
  return cache.get(key, [&] { return build_tone_stage(p); });
}

std::shared_ptr<const SignalStage> cached_signal_stage(const DisplayTarget& t) {
  static StageCache<SignalStage> cache;
  const std::string key = fmt::format("{}|{:.17g}|{:.17g}|{}|{}|{}", static_cast<int>(t.mode), t.peak_nits,
                                      t.black_nits, static_cast<int>(t.range), t.bits, static_cast<int>(t.sdr_curve));
  return cache.get(key, [&] { return build_signal_stage(t); });
}

}  // namespace detail

// ---- Preparation -------------------------------------------------------------------------

namespace {

Result<void> check_input(const SceneInput& in) {
  if (!in.image && !in.half) return make_error("encode.input", "no input image");
  const int w = in.image ? in.image->width : in.half->width;
  const int h = in.image ? in.image->height : in.half->height;
  if (auto ok = check_image_size(w, h); !ok) return ok.error();
  if (in.units == InputUnits::absolute && !(in.white_luminance_nits > 0 && std::isfinite(in.white_luminance_nits)))
    return make_error("encode.input", fmt::format("white luminance {} cd/m2 must be > 0", in.white_luminance_nits),
                      "input.white_luminance");
  return {};
}

}  // namespace

std::vector<float> scene_luminance_nits(const SceneInput& in, double unit_nits, std::size_t max_samples) {
  const std::size_t n = in.image ? in.image->pixel_count() : in.half->pixel_count();
  const std::size_t step = std::max<std::size_t>(1, n / std::max<std::size_t>(1, max_samples));  // ~max_samples
  const Vec3 luma{color::kRec2020Luma.x * in.to_working.m[0][0] + color::kRec2020Luma.y * in.to_working.m[1][0] +
                      color::kRec2020Luma.z * in.to_working.m[2][0],
                  color::kRec2020Luma.x * in.to_working.m[0][1] + color::kRec2020Luma.y * in.to_working.m[1][1] +
                      color::kRec2020Luma.z * in.to_working.m[2][1],
                  color::kRec2020Luma.x * in.to_working.m[0][2] + color::kRec2020Luma.y * in.to_working.m[1][2] +
                      color::kRec2020Luma.z * in.to_working.m[2][2]};
  std::vector<float> out((n + step - 1) / step);
  parallel_for(out.size(), 0, 1 << 16, [&](std::size_t begin, std::size_t end) {
    if (in.image) {
      for (std::size_t k = begin; k < end; ++k) {
        const float* p = in.image->rgba.data() + k * step * 4;
        out[k] = static_cast<float>(color::dot(luma, Vec3{p[0], p[1], p[2]}) * unit_nits);
      }
      return;
    }
    // Half pixels: the halves converted a block at a time by the SIMD kernel (exactly as
    // half_to_float), the sum in double as for float pixels.
    constexpr std::size_t kBlock = 1024;
    float r[kBlock], g[kBlock], b[kBlock];
    for (std::size_t k0 = begin; k0 < end; k0 += kBlock) {
      const std::size_t m = std::min(kBlock, end - k0);
      kernels::strided_half_rgb(in.half->rgba.data() + k0 * step * 4, step, m, r, g, b);
      for (std::size_t i = 0; i < m; ++i)
        out[k0 + i] = static_cast<float>(color::dot(luma, Vec3{r[i], g[i], b[i]}) * unit_nits);
    }
  });
  return out;
}

std::string_view source_peak_param(const tonemap::ToneCurveInfo& curve) {
  for (std::string_view name : {"source_peak_nits", "hdr_max", "scene_max"})
    for (const auto& p : curve.params)
      if (p.name == name) return name;
  return {};
}

void set_exposure_scale(PreparedPipeline& p, double scale) {
  p.metering.scale = scale;
  p.scene_scale = p.unit_nits * scale;
}

namespace {

// Mean maxRGB (cd/m2, container primaries) of the reference path over the sampled pixels.
double predicted_frame_average(const PreparedPipeline& p, const std::vector<Vec3>& px) {
  double sum = 0;
  for (const Vec3& v : px) {
    const Vec3 n = reference_display_nits(p, v);
    sum += std::max({n.x, n.y, n.z, 0.0});
  }
  return px.empty() ? 0.0 : sum / static_cast<double>(px.size());
}

std::vector<Vec3> frame_average_samples(const SceneInput& in) {
  std::vector<Vec3> px;
  const int w = in.image ? in.image->width : in.half ? in.half->width : 0;
  const int h = in.image ? in.image->height : in.half ? in.half->height : 0;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (n == 0) return px;
  const std::size_t step = std::max<std::size_t>(1, n / kFrameAverageSamples);
  px.reserve(n / step + 1);
  for (std::size_t k = 0; k < n; k += step) {
    if (in.image) {
      const float* q = in.image->rgba.data() + k * 4;
      px.push_back(Vec3{q[0], q[1], q[2]});
    } else {
      const auto* q = in.half->rgba.data() + k * 4;
      px.push_back(Vec3{half_to_float(q[0]), half_to_float(q[1]), half_to_float(q[2])});
    }
  }
  return px;
}

}  // namespace

void apply_frame_average_limit(PreparedPipeline& p, const SceneInput& in) {
  const auto limit = p.settings.tone.max_frame_average_nits;
  p.frame_average_limit.reset();
  if (!limit || !p.curve_info) return;
  FrameAverageLimit r;
  r.limit_nits = *limit;
  if (p.curve_info->name == "clip") {
    r.not_applied = "the clip curve's levels are exact (x * paper white)";
  } else if (!p.settings.target.is_hdr()) {
    r.not_applied = "an SDR output";
  }
  const std::vector<Vec3> px = frame_average_samples(in);
  r.predicted_nits = r.limited_nits = predicted_frame_average(p, px);
  if (r.not_applied.empty() && r.predicted_nits > *limit) {
    // The frame average rises with the exposure: bisect the factor in stops, keeping the
    // side that is within the limit, to 1/1000 stop.
    const double scale = p.metering.scale;
    double lo = -40, hi = 0;  // log2 factor: lo within the limit, hi above it
    while (hi - lo > 1e-3) {
      const double mid = 0.5 * (lo + hi);
      set_exposure_scale(p, scale * std::exp2(mid));
      (predicted_frame_average(p, px) <= *limit ? lo : hi) = mid;
    }
    r.exposure_factor = std::exp2(lo);
    set_exposure_scale(p, scale * r.exposure_factor);
    r.limited_nits = predicted_frame_average(p, px);
    r.applied = true;
  }
  p.frame_average_limit = r;
}

std::string_view source_average_param(const tonemap::ToneCurveInfo& curve) {
  for (const auto& p : curve.params)
    if (p.name == "source_avg_nits") return p.name;
  return {};
}

Result<void> set_source_peak(PreparedPipeline& p, std::optional<double> peak_relative,
                             std::optional<double> average_relative) {
  if (!p.curve_info) return make_error("internal", "set_source_peak on a pipeline that is not prepared");
  const auto& t = p.settings.target;
  bool changed = false;
  auto set = [&](std::string_view name, std::optional<double> relative, const char* what) -> Result<void> {
    if (name.empty() || !relative) return {};
    if (!std::isfinite(*relative) || *relative <= 0)
      return make_error("tonemap.peak", fmt::format("source {} {} is not a positive number", what, *relative));
    double value = name.ends_with("_nits") ? *relative * t.paper_white_nits : *relative;
    for (const auto& spec : p.curve_info->params)
      if (spec.name == name) value = std::clamp(value, spec.min, spec.max);
    p.params[std::string(name)] = value;
    changed = true;
    return {};
  };
  if (auto ok = set(source_peak_param(*p.curve_info), peak_relative, "peak"); !ok) return ok;
  if (auto ok = set(source_average_param(*p.curve_info), average_relative, "average"); !ok) return ok;
  if (!changed) return {};
  const tonemap::Display display{t.peak_nits, t.black_nits, t.paper_white_nits};
  p.curve = p.curve_info->prepare(display, p.params);
  return {};
}

Result<PreparedPipeline> prepare_pipeline(const SceneInput& in, const EncodeSettings& s) {
  if (auto ok = validate(s.target); !ok) return ok.error();
  if (auto ok = check_input(in); !ok) return ok.error();
  if (!(s.threads >= 0 && s.threads <= 256)) return make_error("encode.threads", "threads must be in [0, 256]", "threads");
  PreparedPipeline p;
  p.settings = s;
  const auto& t = s.target;
  const std::string curve_name = s.tone.curve.empty() ? std::string(tonemap::default_curve(t.mode)) : s.tone.curve;
  p.curve_info = tonemap::find_curve(curve_name);
  if (!p.curve_info) {
    auto e = tonemap::prepare(curve_name, {});  // produces the "unknown tone curve" message
    return e.error();
  }
  auto params = tonemap::resolve_params(*p.curve_info, s.tone.params);
  if (!params) return params.error();
  p.params = *params;
  const tonemap::Display display{t.peak_nits, t.black_nits, t.paper_white_nits};
  p.curve = p.curve_info->prepare(display, p.params);
  p.apply = s.tone.apply.value_or(p.curve_info->default_apply);
  if (!p.curve_info->scalar) {
    if (s.tone.apply && *s.tone.apply != tonemap::Apply::rgb)
      return make_error("tonemap.apply", fmt::format("tone curve '{}' is an RGB operator; it cannot be applied {}",
                                                     p.curve_info->name, tonemap::to_string(*s.tone.apply)),
                        "tone.apply");
    p.apply = tonemap::Apply::rgb;
  } else if (p.apply == tonemap::Apply::rgb) {
    p.apply = tonemap::Apply::per_channel;
  }
  if (s.ui.overlay) {
    if (s.ui.overlay->width <= 0 || s.ui.overlay->height <= 0) return make_error("ui.overlay", "UI overlay is empty", "ui");
    if (!(s.ui.scale > 0 && s.ui.scale <= 64)) return make_error("ui.scale", "UI scale must be in (0, 64]", "ui.scale");
    if (!(s.ui.dim >= 0 && s.ui.dim <= 1)) return make_error("ui.dim", "UI dim must be in [0, 1]", "ui.dim");
  }
  const double unit_nits = in.units == InputUnits::absolute ? in.white_luminance_nits : t.paper_white_nits;
  exposure::Settings ex = s.exposure;
  if (!ex.illuminance_lux && in.illuminance_lux && *in.illuminance_lux > 0) ex.illuminance_lux = in.illuminance_lux;
  std::shared_ptr<std::vector<float>> samples;
  if (ex.mode == exposure::Mode::log_average || ex.mode == exposure::Mode::histogram)
    samples = std::make_shared<std::vector<float>>(scene_luminance_nits(in, unit_nits));
  auto m = exposure::meter(ex, samples ? std::span<const float>(*samples) : std::span<const float>(), t.paper_white_nits);
  if (!m) return m.error();
  p.metering = *m;
  p.settings.exposure = ex;
  p.input_to_working = in.to_working;
  p.unit_nits = unit_nits;
  p.luminance_nits = std::move(samples);
  p.scene_scale = unit_nits * m->scale;
  p.gamut_mapper = detail::cached_gamut_mapper(s.gamut, in.to_working, t, s.gamut_to_display);
  return p;
}

nlohmann::json PreparedPipeline::describe() const {
  nlohmann::json j;
  j["tone_curve"] = {{"name", curve_info ? curve_info->name : ""},
                     {"apply", tonemap::to_string(apply)},
                     {"params", params}};
  const auto& ex = settings.exposure;
  j["exposure"] = {{"mode", exposure::to_string(ex.mode)},
                   {"compensation_ev", ex.compensation_ev},
                   {"scale", metering.scale},
                   {"metered", metering.metered},
                   {"scene_scale", scene_scale}};
  if (metering.ev100) j["exposure"]["ev100"] = *metering.ev100;
  if (ex.mode == exposure::Mode::histogram)
    j["exposure"]["percentile"] = {{"percentile", ex.percentile ? nlohmann::json(*ex.percentile) : nlohmann::json("window-average")},
                                   {"target", ex.percentile_target},
                                   {"ignore_dark", ex.ignore_dark_fraction}, {"ignore_bright", ex.ignore_bright_fraction}};
  if (ex.mode == exposure::Mode::histogram || ex.mode == exposure::Mode::log_average)
    j["exposure"]["ev100_range"] = {ex.min_ev100, ex.max_ev100};
  if (const auto& l = frame_average_limit) {
    j["exposure"]["frame_average_limit"] = {{"limit_nits", l->limit_nits},
                                            {"applied", l->applied},
                                            {"predicted_nits", l->predicted_nits},
                                            {"limited_nits", l->limited_nits},
                                            {"exposure_factor", l->exposure_factor}};
    if (!l->not_applied.empty()) j["exposure"]["frame_average_limit"]["not_applied"] = l->not_applied;
  }
  j["gamut_mapping"] = to_string(settings.gamut);
  if (settings.gamut_to_display) j["gamut_target"] = detail::display_gamut(settings.target) ? "display" : "container";
  j["dither"] = settings.dither;
  if (settings.grade) j["grade"] = settings.grade->describe();
  if (settings.ui.overlay)
    j["ui"] = {{"width", settings.ui.overlay->width}, {"height", settings.ui.overlay->height},
               {"x", settings.ui.x}, {"y", settings.ui.y}, {"scale", settings.ui.scale},
               {"blend", settings.ui.srgb_blend ? "srgb" : "linear"}, {"dim", settings.ui.dim},
               {"premultiplied", settings.ui.overlay->premultiplied}};
  return j;
}

// ---- Reference path ----------------------------------------------------------------------

Vec3 reference_display_nits(const PreparedPipeline& p, Vec3 input_rgb) {
  const auto& t = p.settings.target;
  Vec3 w = p.input_to_working * detail::sanitize(input_rgb) * p.scene_scale;
  const auto* g = p.settings.grade.get();
  auto apply_grade = [&](Vec3 v) {
    float px[4] = {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z), 1.0f};
    g->apply(px, 1);
    return Vec3{px[0], px[1], px[2]};
  };
  Vec3 nits;
  if (g && g->placement() == grade::Placement::baked) {
    nits = apply_grade(w);
  } else {
    if (g && g->placement() == grade::Placement::scene) w = apply_grade(w);
    w = {std::max(w.x, 0.0), std::max(w.y, 0.0), std::max(w.z, 0.0)};
    if (p.apply == tonemap::Apply::max_rgb) {
      // max(RGB) over the working space and the output container, so that the ratio keeps
      // every output channel at or below the peak (Rec.2020 max alone does not bound Rec.709).
      const Vec3 c = detail::working_to_container(t) * w;
      const double m = std::max({w.x, w.y, w.z, c.x, c.y, c.z});
      const Vec3 y = m > 0 ? w * (p.curve->shape(m) / m) : Vec3{};
      nits = p.curve->lifts_black() ? Vec3{p.curve->lift(y.x), p.curve->lift(y.y), p.curve->lift(y.z)} : y;
      nits = nits * t.paper_white_nits;
    } else {
      nits = p.curve->map_rgb(w, p.apply) * t.paper_white_nits;
    }
    if (g && g->placement() == grade::Placement::display) nits = apply_grade(nits);
  }
  return detail::displayed_light(detail::gamut_map(nits, t, p.settings.gamut, p.gamut_mapper.get()), t);
}

Vec3 reference_signal(const DisplayTarget& t, Vec3 n) {
  switch (t.mode) {
    case Mode::hdr10:
      return {transfer::pq_inverse_eotf(n.x), transfer::pq_inverse_eotf(n.y), transfer::pq_inverse_eotf(n.z)};
    case Mode::hlg:
      return transfer::hlg_inverse_eotf(n, t.peak_nits, t.black_nits);
    case Mode::scrgb:
      return n * (1.0 / transfer::kScrgbUnitNits);
    case Mode::sdr: {
      auto f = [&](double v) {
        const double l = std::clamp(v / t.peak_nits, 0.0, 1.0);
        return t.sdr_curve == SdrCurve::srgb ? transfer::srgb_inverse_eotf(l) : transfer::gamma22_inverse_eotf(l);
      };
      return {f(n.x), f(n.y), f(n.z)};
    }
    case Mode::sdr_bt1886: {
      const auto b = transfer::Bt1886::from_levels(t.peak_nits, t.black_nits);
      return {b.inverse_eotf(n.x), b.inverse_eotf(n.y), b.inverse_eotf(n.z)};
    }
  }
  return n;
}

}  // namespace hdrd

#include "encode/tone/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "encode/tone/scene_cut.hpp"

namespace hdrd::exposure {

std::string_view to_string(Mode m) {
  switch (m) {
    case Mode::manual: return "manual";
    case Mode::camera: return "camera";
    case Mode::log_average: return "log-average";
    case Mode::histogram: return "histogram";
    case Mode::light: return "light";
  }
  return "?";
}

std::optional<Mode> parse_mode(std::string_view s) {
  for (Mode m : {Mode::manual, Mode::camera, Mode::log_average, Mode::histogram, Mode::light})
    if (to_string(m) == s) return m;
  if (s == "auto") return Mode::histogram;
  if (s == "ev100") return Mode::camera;
  return std::nullopt;
}

double ev100_from_camera(double aperture_f, double shutter_s, double iso) {
  return std::log2(aperture_f * aperture_f / shutter_s * 100.0 / iso);
}

double scale_from_ev100(double ev100) {
  // L_max = 78 / (q S) * 2^EV100 with q = 0.65, S = 100: the luminance that saturates the sensor.
  return 1.0 / (1.2 * std::exp2(ev100));
}

namespace {

Result<void> check_settings(const Settings& s) {
  auto bad = [](const char* field, std::string msg) { return make_error("exposure.invalid", std::move(msg), field); };
  if (!std::isfinite(s.compensation_ev) || std::abs(s.compensation_ev) > 64)
    return bad("exposure.compensation_ev", fmt::format("exposure compensation {} EV is not within +-64", s.compensation_ev));
  if (!std::isfinite(s.gain) || s.gain <= 0) return bad("exposure.gain", fmt::format("gain {} must be > 0", s.gain));
  if (s.ev100 && (!std::isfinite(*s.ev100) || std::abs(*s.ev100) > 64))
    return bad("exposure.ev100", fmt::format("EV100 {} is not within +-64", *s.ev100));
  if (!(s.aperture_f > 0 && s.aperture_f < 1000)) return bad("exposure.aperture", "aperture must be in (0, 1000)");
  if (!(s.shutter_s > 0 && s.shutter_s < 1e5)) return bad("exposure.shutter", "shutter time must be in (0, 1e5) s");
  if (!(s.iso > 0 && s.iso < 1e7)) return bad("exposure.iso", "ISO must be in (0, 1e7)");
  if (s.percentile && !(*s.percentile >= 0 && *s.percentile <= 100))
    return bad("exposure.percentile", "percentile must be in [0, 100]");
  if (!(std::isfinite(s.min_ev100) && std::isfinite(s.max_ev100) && s.min_ev100 <= s.max_ev100))
    return bad("exposure.min_ev100",
               fmt::format("exposure.min_ev100 {} must not be above exposure.max_ev100 {}", s.min_ev100, s.max_ev100));
  if (!(s.percentile_target > 0 && s.percentile_target < 1e4))
    return bad("exposure.percentile_target", "percentile target must be > 0");
  if (!(s.ignore_dark_fraction >= 0 && s.ignore_bright_fraction >= 0 &&
        s.ignore_dark_fraction + s.ignore_bright_fraction < 1))
    return bad("exposure.ignore", "ignore fractions must be >= 0 and sum to less than 1");
  if (s.illuminance_lux && !(*s.illuminance_lux > 0 && std::isfinite(*s.illuminance_lux)))
    return bad("exposure.illuminance_lux", "illuminance must be > 0 lux");
  if (!(s.adaptation_time_s >= 0 && s.adaptation_time_s <= 1000))
    return bad("exposure.adaptation_time_s", "adaptation time must be within [0, 1000] s");
  for (auto [v, field] : {std::pair{s.adaptation_brighten_time_s, "exposure.adaptation_brighten_time_s"},
                          std::pair{s.adaptation_darken_time_s, "exposure.adaptation_darken_time_s"}})
    if (v && !(*v >= 0 && *v <= 1000)) return bad(field, fmt::format("{} must be within [0, 1000] s", field));
  return {};
}

// A floor for metered luminance so a black frame does not produce an infinite gain.
constexpr double kMinMeteredNits = 1e-4;

// Unreal's clamp of a metered exposure: a camera's EV100 within [min, max].
double clamp_metered_scale(const Settings& s, double scale, Metering& m) {
  const double ev = std::clamp(ev100_from_scale(scale), s.min_ev100, s.max_ev100);
  m.ev100 = ev;
  return ev == ev100_from_scale(scale) ? scale : scale_from_ev100(ev);
}

}  // namespace

double ev100_from_scale(double scale) { return std::log2(1.0 / (1.2 * scale)); }

double histogram_window_nits(std::span<const float> luminance_nits, double dark, double bright,
                             std::optional<double> percentile) {
  const auto h = temporal::LuminanceHistogram::of(luminance_nits);
  using H = temporal::LuminanceHistogram;
  const double n = static_cast<double>(h.total());
  if (n == 0) return 0.0;
  const double lo = dark * n, hi = std::max((1.0 - bright) * n, lo);
  if (percentile) return h.percentile(100.0 * (lo + *percentile / 100.0 * (hi - lo)) / n);
  // The window's mean in stops, each bin at its centre (black and the darkest bins at the
  // metering floor); a window of zero width reads the bin it falls in.
  const double floor_log2 = std::log2(kMinMeteredNits);
  double below = 0, weight = 0, sum = 0;
  for (int i = 0; i < H::kBins; ++i) {
    const double c = h.counts()[static_cast<std::size_t>(i)];
    if (c == 0) continue;
    const double w = hi > lo ? std::max(0.0, std::min(below + c, hi) - std::max(below, lo))
                             : (lo >= below && lo <= below + c ? 1.0 : 0.0);
    below += c;
    if (w <= 0) continue;
    const double centre = i == 0 ? floor_log2 : std::log2(H::lower_edge(i)) + 0.5 / H::kBinsPerStop;
    sum += w * std::max(centre, floor_log2);
    weight += w;
    if (hi <= lo) break;
  }
  return weight > 0 ? std::exp2(sum / weight) : 0.0;
}

Result<Metering> meter(const Settings& s, std::span<const float> luminance_nits, double paper_white_nits) {
  if (auto ok = check_settings(s); !ok) return ok.error();
  Metering m;
  const double comp = std::exp2(s.compensation_ev);
  switch (s.mode) {
    case Mode::manual:
      m.scale = s.gain / paper_white_nits;
      m.metered = paper_white_nits / s.gain;
      break;
    case Mode::camera: {
      const double ev = s.ev100 ? *s.ev100 : ev100_from_camera(s.aperture_f, s.shutter_s, s.iso);
      m.ev100 = ev;
      m.scale = scale_from_ev100(ev);
      m.metered = ev;
      break;
    }
    case Mode::log_average: {
      // Reinhard 2002 eq. 1: key = exp(mean(log(eps + L))); scale maps it to mid grey.
      const double eps = kLogAverageEpsilon * paper_white_nits;
      double sum = 0;
      std::size_t n = 0;
      for (float x : luminance_nits) {
        if (!std::isfinite(x)) continue;
        sum += std::log(eps + std::max<double>(x, 0.0));
        ++n;
      }
      if (n == 0) return make_error("exposure.empty", "log-average metering found no finite pixels", "exposure.mode");
      m.metered = std::max(std::exp(sum / n), kMinMeteredNits);
      m.scale = clamp_metered_scale(s, kMidGrey / m.metered, m);
      break;
    }
    case Mode::histogram: {
      // Unreal's histogram exposure: drop the darkest and brightest fractions, average the
      // rest in stops (or read a percentile of it: Valve's median); a few bright pixels
      // (the sun, a chrome ball's highlight) cannot move it.
      const double w = histogram_window_nits(luminance_nits, s.ignore_dark_fraction, s.ignore_bright_fraction, s.percentile);
      if (!(w > 0) && std::none_of(luminance_nits.begin(), luminance_nits.end(), [](float x) { return std::isfinite(x); }))
        return make_error("exposure.empty", "histogram metering found no finite pixels", "exposure.mode");
      m.metered = std::max(w, kMinMeteredNits);
      m.scale = clamp_metered_scale(s, s.percentile_target / m.metered, m);
      break;
    }
    case Mode::light: {
      if (!s.illuminance_lux)
        return make_error("exposure.light",
                          "light-based exposure needs the dominant illuminance (a rendered scene's sun, or "
                          "--illuminance LUX)",
                          "exposure.illuminance_lux");
      // Incident metering: a white Lambertian card under E has L = E / pi -> 1.0.
      m.metered = *s.illuminance_lux;
      m.scale = std::numbers::pi / *s.illuminance_lux;
      break;
    }
  }
  m.scale *= comp;
  return m;
}

}  // namespace hdrd::exposure

#include "encode/tone/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include <fmt/format.h>

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
  if (!(s.percentile >= 0 && s.percentile <= 100)) return bad("exposure.percentile", "percentile must be in [0, 100]");
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

std::vector<float> finite_positive(std::span<const float> l) {
  std::vector<float> v;
  v.reserve(l.size());
  for (float x : l)
    if (std::isfinite(x)) v.push_back(std::max(x, 0.0f));
  return v;
}

// A floor for metered luminance so a black frame does not produce an infinite gain.
constexpr double kMinMeteredNits = 1e-4;

}  // namespace

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
      m.scale = kMidGrey / m.metered;
      break;
    }
    case Mode::histogram: {
      std::vector<float> v = finite_positive(luminance_nits);
      if (v.empty()) return make_error("exposure.empty", "histogram metering found no finite pixels", "exposure.mode");
      // Drop the darkest and brightest fractions, then take the percentile of what is left
      // (Valve: median -> mid grey; a few bright pixels cannot move it).
      const double n = static_cast<double>(v.size());
      const double lo = s.ignore_dark_fraction * n;
      const double kept = n * (1.0 - s.ignore_dark_fraction - s.ignore_bright_fraction);
      auto idx = static_cast<std::size_t>(std::clamp(lo + s.percentile / 100.0 * std::max(kept - 1, 0.0), 0.0, n - 1));
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(idx), v.end());
      m.metered = std::max<double>(v[idx], kMinMeteredNits);
      m.scale = s.percentile_target / m.metered;
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

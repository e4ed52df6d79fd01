#include "encode/tone/adaptation.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "encode/tone/exposure.hpp"

namespace hdrd::temporal {

double LogSmoother::update(double target, double dt_s) {
  // Callers check their input; an unusable target holds the state rather than poison it.
  if (!(target > 0) || !std::isfinite(target)) return value().value_or(1.0);
  const double t = std::log2(target);
  const double tau = t > log2_value_ ? rise_s_ : fall_s_;
  if (!have_ || tau <= 0) {
    // Taken as it is, and kept bit for bit while it does not change: a static scene (or
    // manual exposure) gives each frame exactly the single-frame value.
    log2_value_ = t, value_ = target, have_ = true;
  } else if (t != log2_value_) {
    // Exact solution of d(log2 S)/dt = (log2 T - log2 S) / tau over dt, so the result does
    // not depend on how the interval is split into frames.
    log2_value_ += (t - log2_value_) * -std::expm1(-std::max(dt_s, 0.0) / tau);
    value_ = std::exp2(log2_value_);
  }
  return value_;
}

std::optional<double> LogSmoother::value() const {
  if (!have_) return std::nullopt;
  return value_;
}

AdaptationSettings adaptation_settings(const exposure::Settings& s) {
  AdaptationSettings a;
  a.brighten_time_s = s.adaptation_brighten_time_s.value_or(s.adaptation_time_s);
  a.darken_time_s = s.adaptation_darken_time_s.value_or(s.adaptation_time_s);
  return a;
}

Result<void> validate(const AdaptationSettings& s) {
  // 1000 s: longer than any adaptation of the eye (full dark adaptation takes ~30 min, but
  // no exposure system models that) and the bound the request parser already uses.
  auto check = [](double v, const char* field) -> Result<void> {
    if (!(v >= 0 && v <= 1000))
      return make_error("exposure.invalid", fmt::format("{} = {} s is not within [0, 1000]", field, v), field);
    return {};
  };
  if (auto r = check(s.brighten_time_s, "exposure.adaptation_brighten_time_s"); !r) return r;
  return check(s.darken_time_s, "exposure.adaptation_darken_time_s");
}

Result<double> ExposureAdaptation::next(double own_scale, double dt_s, bool scene_start) {
  if (!(own_scale > 0) || !std::isfinite(own_scale))
    return make_error("exposure.scale", fmt::format("metered exposure scale {} is not a positive number", own_scale),
                      "exposure");
  if (!(dt_s >= 0) || !std::isfinite(dt_s))
    return make_error("sequence.time", fmt::format("frame interval {} s is not a non-negative number", dt_s), "fps");
  const bool restart = scene_start || !previous_own_;
  if (restart) smoother_.reset();
  double target = own_scale;
  if (!restart && settings_.adapting() && settings_.meter_previous_frame) target = *previous_own_;
  previous_own_ = own_scale;
  return smoother_.update(target, dt_s);
}

void ExposureAdaptation::reset() {
  smoother_.reset();
  previous_own_.reset();
}

}  // namespace hdrd::temporal

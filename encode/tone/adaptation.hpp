// Temporal exposure for sequences (RTR4 §8.2.2). A renderer meters the frame it has and
// exposes the next one with it; the eye (and a camera's auto exposure) does not jump to a
// new level but approaches it exponentially. Both happen in stops: after a step from S0 to
// a target T, log2 S(t) = log2 T + (log2 S0 - log2 T) exp(-t / tau), with one time
// constant while the exposure rises (the scene got darker) and another while it falls
// (the scene got brighter). A scene cut resets it: the first frame of a new scene is
// exposed from its own metering, as a single frame would be.
#pragma once

#include <optional>

#include "encode/result.hpp"

namespace hdrd::exposure {
struct Settings;
}

namespace hdrd::temporal {

// First-order exponential smoothing of a positive quantity in log2 (stops), with separate
// time constants for rising and falling values (0 = follow at once). Shared by exposure
// adaptation and dynamic peak detection.
class LogSmoother {
 public:
  LogSmoother(double rise_time_s, double fall_time_s) : rise_s_(rise_time_s), fall_s_(fall_time_s) {}
  // Moves toward `target` (finite, > 0) over dt_s seconds and returns the smoothed value;
  // the first value after construction or reset() is taken as it is.
  double update(double target, double dt_s);
  void reset() { have_ = false; }
  std::optional<double> value() const;

 private:
  double rise_s_, fall_s_;
  double log2_value_ = 0;
  double value_ = 1;  // exp2(log2_value_), or the target itself when it was taken as it is
  bool have_ = false;
};

struct AdaptationSettings {
  double brighten_time_s = 0;  // time constant while the exposure scale rises (into the dark)
  double darken_time_s = 0;    // while it falls (into the light)
  // RTR4 §8.2.2: frame n is exposed from frame n-1's metering. Only while adapting: with
  // both time constants 0 every frame is exposed from its own metering (a single frame).
  bool meter_previous_frame = true;
  bool adapting() const { return brighten_time_s > 0 || darken_time_s > 0; }
};
// exposure.adaptation_time_s sets both directions; adaptation_brighten_time_s and
// adaptation_darken_time_s, when given, override one each.
AdaptationSettings adaptation_settings(const exposure::Settings& s);
Result<void> validate(const AdaptationSettings& s);

class ExposureAdaptation {
 public:
  explicit ExposureAdaptation(const AdaptationSettings& s)
      : settings_(s), smoother_(s.brighten_time_s, s.darken_time_s) {}
  // own_scale: what exposure::meter gives for this frame alone (> 0); dt_s: time since the
  // previous frame; scene_start: first frame of the sequence or of a new scene. Returns
  // the scale to expose this frame with.
  Result<double> next(double own_scale, double dt_s, bool scene_start);
  void reset();

 private:
  AdaptationSettings settings_;
  LogSmoother smoother_;
  std::optional<double> previous_own_;
};

}  // namespace hdrd::temporal

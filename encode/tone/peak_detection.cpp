#include "encode/tone/peak_detection.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace hdrd::temporal {

Result<void> validate(const PeakDetectionSettings& s) {
  if (!(s.percentile > 50 && s.percentile <= 100))
    return make_error("tonemap.peak_detection",
                      fmt::format("peak percentile {} is not within (50, 100]", s.percentile),
                      "tonemap.peak_percentile");
  for (auto [v, field] : {std::pair{s.rise_time_s, "tonemap.peak_rise_time_s"},
                          std::pair{s.fall_time_s, "tonemap.peak_fall_time_s"}})
    if (!(v >= 0 && v <= 1000))
      return make_error("tonemap.peak_detection", fmt::format("{} = {} s is not within [0, 1000]", field, v), field);
  return {};
}

Result<double> PeakDetector::next(const LuminanceHistogram& frame, double exposure_scale, double dt_s,
                                  bool scene_start) {
  if (!(exposure_scale > 0) || !std::isfinite(exposure_scale))
    return make_error("exposure.scale", fmt::format("exposure scale {} is not a positive number", exposure_scale),
                      "exposure");
  if (!(dt_s >= 0) || !std::isfinite(dt_s))
    return make_error("sequence.time", fmt::format("frame interval {} s is not a non-negative number", dt_s), "fps");
  if (scene_start) smoother_.reset();
  // A black frame has no peak: hold it at the histogram's floor so the log stays finite.
  const double floor_nits = LuminanceHistogram::lower_edge(1);
  const double peak_nits = std::max(frame.percentile(settings_.percentile), floor_nits);
  return smoother_.update(peak_nits * exposure_scale, dt_s);
}

}  // namespace hdrd::temporal

#include "encode/tone/temporal.hpp"

#include <algorithm>
#include <cmath>

namespace hdrd::temporal {

Result<void> validate(const TemporalSettings& s) {
  if (auto r = validate(s.adaptation); !r) return r;
  if (auto r = validate(s.scene_cut); !r) return r;
  return validate(s.peak);
}

Result<FrameDecision> TemporalTone::next(std::span<const float> luminance_nits, const exposure::Settings& exposure,
                                         double paper_white_nits, double dt_s, bool given_cut) {
  auto metering = exposure::meter(exposure, luminance_nits, paper_white_nits);
  if (!metering) return metering.error();
  return next_metered(luminance_nits, metering->scale, dt_s, given_cut);
}

Result<FrameDecision> TemporalTone::next_metered(std::span<const float> luminance_nits, double own_scale, double dt_s,
                                                 bool given_cut) {
  FrameDecision d;
  const LuminanceHistogram histogram = LuminanceHistogram::of(luminance_nits);
  const bool detected = cuts_.next(histogram);
  d.cut_distance_stops = first_ ? 0.0 : cuts_.last_distance();  // nothing before the first frame
  d.scene_start = first_ || given_cut || (settings_.detect_cuts && detected);
  first_ = false;
  d.own_scale = own_scale;
  auto scale = adaptation_.next(d.own_scale, dt_s, d.scene_start);
  if (!scale) return scale.error();
  d.exposure_scale = *scale;
  auto peak = peak_.next(histogram, d.exposure_scale, dt_s, d.scene_start);
  if (!peak) return peak.error();
  d.source_peak = *peak;
  // The frame's mean luminance (NaN and Inf ignored, negatives as black), held above the
  // histogram's black floor so the smoothing in stops stays finite on a black frame.
  double sum = 0;
  std::size_t n = 0;
  for (float v : luminance_nits)
    if (std::isfinite(v)) sum += std::max(v, 0.0f), ++n;
  const double mean_nits = std::max(n ? sum / static_cast<double>(n) : 0.0, LuminanceHistogram::lower_edge(1));
  if (d.scene_start) average_.reset();
  d.source_average = average_.update(mean_nits * d.exposure_scale, dt_s);
  return d;
}

}  // namespace hdrd::temporal

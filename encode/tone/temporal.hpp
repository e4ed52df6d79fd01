// The time axis of exposure and tone mapping, one call per frame: scene-cut detection
// (scene_cut.hpp), exposure adaptation (adaptation.hpp) and dynamic source-peak detection
// (peak_detection.hpp) over the frame's scene luminance, in that order, so a cut resets
// both the exposure and the peak on the frame where it happens. Pure and deterministic:
// the same frames give the same decisions; memory is one histogram.
#pragma once

#include <span>

#include "encode/result.hpp"
#include "encode/tone/adaptation.hpp"
#include "encode/tone/exposure.hpp"
#include "encode/tone/peak_detection.hpp"
#include "encode/tone/scene_cut.hpp"

namespace hdrd::temporal {

struct TemporalSettings {
  AdaptationSettings adaptation;
  SceneCutSettings scene_cut;
  PeakDetectionSettings peak;
  bool detect_cuts = true;  // false: only the cuts the caller gives start scenes
};
Result<void> validate(const TemporalSettings& s);

struct FrameDecision {
  bool scene_start = false;
  double cut_distance_stops = 0;  // light moved since the previous frame (scene_cut.hpp)
  double own_scale = 1;         // this frame's metering alone (exposure::meter)
  double exposure_scale = 1;    // what to expose it with (settings.exposure.scale)
  double source_peak = 1;       // the tone curve's source peak, relative (x paper white = nits)
  // The scene's average light, relative: the mean luminance (linear, as HDR10+'s average
  // maxRGB), smoothed as the peak is and reset with it; curves that place a knee on the
  // average (spline, st2094-40, st2094-10: source_avg_nits) follow it.
  double source_average = 0;
};

class TemporalTone {
 public:
  explicit TemporalTone(const TemporalSettings& s)
      : settings_(s), cuts_(s.scene_cut), adaptation_(s.adaptation), peak_(s.peak) {}
  // luminance_nits: the frame's scene luminance samples (what exposure::meter reads, e.g.
  // its ~2 Mpx subsample); dt_s: time since the previous frame; given_cut: the caller
  // knows a scene starts here (keyframed scene change, a new input file).
  Result<FrameDecision> next(std::span<const float> luminance_nits, const exposure::Settings& exposure,
                             double paper_white_nits, double dt_s, bool given_cut = false);
  // The same, when the caller has metered the frame already (own_scale: exposure::meter's
  // scale on the same samples, e.g. PreparedPipeline::metering.scale).
  Result<FrameDecision> next_metered(std::span<const float> luminance_nits, double own_scale, double dt_s,
                                     bool given_cut = false);

 private:
  TemporalSettings settings_;
  SceneCutDetector cuts_;
  ExposureAdaptation adaptation_;
  PeakDetector peak_;
  LogSmoother average_{settings_.peak.rise_time_s, settings_.peak.fall_time_s};
  bool first_ = true;
};

}  // namespace hdrd::temporal

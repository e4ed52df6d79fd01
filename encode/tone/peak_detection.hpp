// Dynamic source-peak detection for tone curves that take a source peak (bt2390's
// source_peak_nits, lottes-hdr's hdr_max): as video players do (libplacebo's peak
// detection: a high percentile per frame, smoothed over about 20 frames, reset at scene
// changes), the peak is a high percentile of the frame's luminance, smoothed in stops
// and reset at scene cuts. It rises faster than it falls so a new highlight is rolled off
// soon rather than clipped, and a one-frame glint cannot make the picture pump.
#pragma once

#include "encode/result.hpp"
#include "encode/tone/adaptation.hpp"
#include "encode/tone/scene_cut.hpp"

namespace hdrd::temporal {

struct PeakDetectionSettings {
  // libplacebo uses 99.995 %; at 1080p 99.99 % leaves out the brightest ~200 pixels,
  // which keeps a few specular sparkles from setting the peak of the whole frame.
  double percentile = 99.99;
  double rise_time_s = 0.25;  // time constant (stops) while the peak rises
  double fall_time_s = 1.0;   // while it falls
};
Result<void> validate(const PeakDetectionSettings& s);

class PeakDetector {
 public:
  explicit PeakDetector(const PeakDetectionSettings& s = {}) : settings_(s), smoother_(s.rise_time_s, s.fall_time_s) {}
  // frame: the frame's scene luminance (cd/m2) before exposure; exposure_scale: the scale
  // this frame is exposed with (cd/m2 -> relative). Returns the source peak in the tone
  // curve's input units (relative, 1.0 = diffuse white; x paper white for nits).
  Result<double> next(const LuminanceHistogram& frame, double exposure_scale, double dt_s, bool scene_start);
  void reset() { smoother_.reset(); }

 private:
  PeakDetectionSettings settings_;
  LogSmoother smoother_;
};

}  // namespace hdrd::temporal

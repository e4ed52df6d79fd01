// Scene cuts from the light distribution. A frame's luminance histogram is binned in stops
// (log2 cd/m2, from the float's exponent and top mantissa bits: one shift per sample, 8
// bins per octave). Consecutive frames are compared by the earth mover's distance of
// their distributions in stops, D = integral |F_a(s) - F_b(s)| ds over log2 luminance s
// (F: the cumulative distributions): how far, on average, the picture's light moved.
// A pure change of light by k stops gives D = k whatever the picture; a camera move or a
// slow light ramp moves little per frame; a cut to another place or time of day moves
// most of the light by several stops. D > threshold (default 2 stops) starts a new scene.
// A cut that leaves the light where it was (two interiors alike) is not found, and needs
// no reset: the exposure and the peak would be what they are.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "encode/result.hpp"

namespace hdrd::temporal {

class LuminanceHistogram {
 public:
  static constexpr int kMinLog2Nits = -20;  // ~1e-6 cd/m2: below it counts as black
  static constexpr int kMaxLog2Nits = 32;   // ~4e9 cd/m2: above the sun's disc (1.6e9)
  static constexpr int kBinsPerStop = 8;
  static constexpr int kBins = (kMaxLog2Nits - kMinLog2Nits) * kBinsPerStop + 1;  // bin 0: black

  // Luminance samples in cd/m2; NaN and Inf are ignored, zero and negatives count as black.
  void add(std::span<const float> luminance_nits);
  static LuminanceHistogram of(std::span<const float> luminance_nits);

  std::uint64_t total() const { return total_; }
  const std::array<std::uint32_t, kBins>& counts() const { return counts_; }
  // The p-th percentile (p in [0, 100]) in cd/m2, linear inside its bin (error below one
  // bin: < 1/11 stop); 0 when it falls among the black samples or nothing was added.
  double percentile(double p) const;
  // Bin edges in cd/m2: bin i covers [lower_edge(i), lower_edge(i + 1)).
  static double lower_edge(int bin);

 private:
  std::array<std::uint32_t, kBins> counts_{};
  std::uint64_t total_ = 0;
};

// Earth mover's distance between two histograms' distributions, in stops. Light below
// kDistanceFloorLog2Nits (black included) counts as lying at that floor, so a few pixels
// going black do not weigh as if they fell twenty stops. Empty histograms: 0 when both
// are, kNoPictureStops when one is.
inline constexpr int kDistanceFloorLog2Nits = -14;  // ~6e-5 cd/m2, below any display's black
inline constexpr double kNoPictureStops = 64;
double histogram_distance_stops(const LuminanceHistogram& a, const LuminanceHistogram& b);

struct SceneCutSettings {
  // Synthetic checks (tests/encode/tone/temporal_test.cpp): a slow pan, a 1/10-stop-per-
  // frame light ramp and render noise stay below 0.25 stops; cuts between shots lit 3.7
  // stops or more apart exceed 3.
  double threshold_stops = 2.0;
};
Result<void> validate(const SceneCutSettings& s);

class SceneCutDetector {
 public:
  explicit SceneCutDetector(SceneCutSettings s = {}) : settings_(s) {}
  // True when this frame starts a new scene; the first frame always does.
  bool next(const LuminanceHistogram& frame);
  double last_distance() const { return last_distance_; }  // stops; kNoPictureStops for the first frame
  void reset() { have_previous_ = false; }

 private:
  SceneCutSettings settings_;
  LuminanceHistogram previous_;
  bool have_previous_ = false;
  double last_distance_ = kNoPictureStops;
};

}  // namespace hdrd::temporal

#include "encode/tone/scene_cut.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include <fmt/format.h>

namespace hdrd::temporal {

namespace {

constexpr int kMantissaBits = 3;  // 2^3 = kBinsPerStop
static_assert((1 << kMantissaBits) == LuminanceHistogram::kBinsPerStop);
constexpr std::uint32_t kMinBits = static_cast<std::uint32_t>(127 + LuminanceHistogram::kMinLog2Nits) << 23;

// Bin of one sample: the float's bits above the top mantissa bits, relative to 2^kMin.
inline int bin_of(float v) {
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
  if (static_cast<std::int32_t>(bits) < static_cast<std::int32_t>(kMinBits)) return 0;  // < 2^min, 0, negatives
  const std::uint32_t rel = (bits - kMinBits) >> (23 - kMantissaBits);
  return static_cast<int>(std::min<std::uint32_t>(rel + 1, LuminanceHistogram::kBins - 1));
}

}  // namespace

void LuminanceHistogram::add(std::span<const float> luminance_nits) {
  std::uint64_t added = 0;
  for (float v : luminance_nits) {
    if (!std::isfinite(v)) continue;
    ++counts_[static_cast<std::size_t>(bin_of(v))];
    ++added;
  }
  total_ += added;
}

LuminanceHistogram LuminanceHistogram::of(std::span<const float> luminance_nits) {
  LuminanceHistogram h;
  h.add(luminance_nits);
  return h;
}

double LuminanceHistogram::lower_edge(int bin) {
  if (bin <= 0) return 0.0;
  const int octave = (bin - 1) / kBinsPerStop, step = (bin - 1) % kBinsPerStop;
  return std::ldexp(1.0 + static_cast<double>(step) / kBinsPerStop, kMinLog2Nits + octave);
}

double LuminanceHistogram::percentile(double p) const {
  if (total_ == 0) return 0.0;
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(total_);
  double below = 0;
  for (int i = 0; i < kBins; ++i) {
    const double n = counts_[static_cast<std::size_t>(i)];
    if (n == 0) continue;
    if (below + n >= rank || i == kBins - 1) {
      if (i == 0) return 0.0;
      const double f = std::clamp((rank - below) / n, 0.0, 1.0);
      const double lo = lower_edge(i), hi = lower_edge(i + 1);
      return lo + f * (hi - lo);
    }
    below += n;
  }
  return lower_edge(kBins - 1);
}

double histogram_distance_stops(const LuminanceHistogram& a, const LuminanceHistogram& b) {
  if (a.total() == 0 || b.total() == 0) return a.total() == b.total() ? 0.0 : kNoPictureStops;
  using H = LuminanceHistogram;
  const double na = static_cast<double>(a.total()), nb = static_cast<double>(b.total());
  // Bins below the floor (and black, bin 0) only add to both cumulative sums.
  const int first = 1 + (kDistanceFloorLog2Nits - H::kMinLog2Nits) * H::kBinsPerStop;
  double ca = 0, cb = 0, stops = 0;
  for (int i = 0; i < H::kBins - 1; ++i) {
    ca += a.counts()[static_cast<std::size_t>(i)];
    cb += b.counts()[static_cast<std::size_t>(i)];
    if (i < first) continue;
    // Each bin's light sits at its lower edge, so |F_a - F_b| is constant across the bin.
    const double width = std::log2(H::lower_edge(i + 1) / H::lower_edge(i));
    stops += std::abs(ca / na - cb / nb) * width;
  }
  return stops;
}

Result<void> validate(const SceneCutSettings& s) {
  if (!(s.threshold_stops > 0 && s.threshold_stops <= 32))
    return make_error("sequence.scene_cut",
                      fmt::format("scene-cut threshold {} stops is not within (0, 32]", s.threshold_stops),
                      "sequence.scene_cut_threshold_stops");
  return {};
}

bool SceneCutDetector::next(const LuminanceHistogram& frame) {
  last_distance_ = have_previous_ ? histogram_distance_stops(previous_, frame) : kNoPictureStops;
  const bool cut = !have_previous_ || last_distance_ > settings_.threshold_stops;
  previous_ = frame;
  have_previous_ = true;
  return cut;
}

}  // namespace hdrd::temporal

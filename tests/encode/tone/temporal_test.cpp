// The time axis (encode/tone/temporal.hpp): exposure adaptation against the exponential
// model in stops (RTR4 §8.2.2), scene-cut detection on synthetic sequences with and without
// cuts, dynamic peak detection, and the reset at a cut.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "encode/tone/temporal.hpp"

using namespace hdrd;
using namespace hdrd::temporal;

namespace {

// The model the smoothing must follow exactly: after a step to T, k frames of dt later,
// log2 S = log2 T + (log2 S0 - log2 T) exp(-k dt / tau).
double model_stops(double s0, double target, double tau_s, double t_s) {
  return std::log2(target) + (std::log2(s0) - std::log2(target)) * std::exp(-t_s / tau_s);
}

TEST(LogSmoother, StepResponseFollowsTheExponentialInStops) {
  LogSmoother s(2.0, 0.5);  // rise tau 2 s, fall tau 0.5 s
  const double dt = 1.0 / 24;
  EXPECT_DOUBLE_EQ(s.update(1.0, dt), 1.0);  // first value taken as it is
  for (int k = 1; k <= 96; ++k) EXPECT_NEAR(std::log2(s.update(16.0, dt)), model_stops(1.0, 16.0, 2.0, k * dt), 1e-12);
  const double top = *s.value();
  for (int k = 1; k <= 48; ++k)
    EXPECT_NEAR(std::log2(s.update(0.25, dt)), model_stops(top, 0.25, 0.5, k * dt), 1e-12) << k;
}

TEST(LogSmoother, ResultDoesNotDependOnHowTimeIsSplit) {
  LogSmoother a(1.0, 1.0), b(1.0, 1.0);
  a.update(1, 0), b.update(1, 0);
  const double one = a.update(8, 0.1);
  b.update(8, 0.05);
  EXPECT_NEAR(b.update(8, 0.05), one, 1e-12);
}

TEST(LogSmoother, UnusableTargetsHoldTheState) {
  LogSmoother s(1, 1);
  s.update(4, 0);
  EXPECT_DOUBLE_EQ(s.update(NAN, 1), 4);
  EXPECT_DOUBLE_EQ(s.update(-1, 1), 4);
  EXPECT_DOUBLE_EQ(s.update(INFINITY, 1), 4);
}

AdaptationSettings adapting(double brighten_s, double darken_s) {
  AdaptationSettings a;
  a.brighten_time_s = brighten_s;
  a.darken_time_s = darken_s;
  return a;
}

TEST(ExposureAdaptation, StaticSceneGivesIdenticalFrames) {
  ExposureAdaptation a(adapting(1.0, 0.3));
  const double first = *a.next(0.0123, 1.0 / 30, true);
  for (int i = 0; i < 300; ++i) EXPECT_EQ(*a.next(0.0123, 1.0 / 30, false), first) << i;
}

TEST(ExposureAdaptation, StepIntoTheDarkFollowsTheBrightenTimeOneFrameLate) {
  // Metering from the previous frame: the frame where the light drops is still exposed for
  // the old light; from the next frame on the exposure rises with the brighten constant.
  const double dt = 1.0 / 24, tau = 0.8;
  ExposureAdaptation a(adapting(tau, 0.1));
  for (int i = 0; i < 5; ++i) ASSERT_DOUBLE_EQ(*a.next(1.0, dt, i == 0), 1.0);
  EXPECT_DOUBLE_EQ(*a.next(32.0, dt, false), 1.0);  // five stops darker scene, not a cut
  for (int k = 1; k <= 72; ++k)
    EXPECT_NEAR(std::log2(*a.next(32.0, dt, false)), model_stops(1.0, 32.0, tau, k * dt), 1e-12) << k;
}

TEST(ExposureAdaptation, StepIntoTheLightUsesTheDarkenTime) {
  const double dt = 1.0 / 60, tau = 0.25;
  ExposureAdaptation a(adapting(3.0, tau));
  ASSERT_TRUE(a.next(1.0, dt, true).ok());
  ASSERT_DOUBLE_EQ(*a.next(1.0 / 64, dt, false), 1.0);  // the lag frame
  for (int k = 1; k <= 60; ++k)
    EXPECT_NEAR(std::log2(*a.next(1.0 / 64, dt, false)), model_stops(1.0, 1.0 / 64, tau, k * dt), 1e-12) << k;
}

TEST(ExposureAdaptation, CutResetsToTheNewSceneOwnMetering) {
  ExposureAdaptation a(adapting(2.0, 2.0));
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(a.next(1.0, 0.04, i == 0).ok());
  EXPECT_DOUBLE_EQ(*a.next(0.002, 0.04, true), 0.002);  // exactly as a single frame
  EXPECT_DOUBLE_EQ(*a.next(0.002, 0.04, false), 0.002);  // and stays: its previous frame agrees
}

TEST(ExposureAdaptation, WithoutAdaptationEveryFrameIsItsOwnMetering) {
  ExposureAdaptation a(AdaptationSettings{});
  for (double s : {1.0, 8.0, 0.01, 3.0}) EXPECT_DOUBLE_EQ(*a.next(s, 0.04, false), s);
}

TEST(ExposureAdaptation, BadInputNamesWhatIsWrong) {
  ExposureAdaptation a(adapting(1, 1));
  auto r = a.next(NAN, 0.04, false);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "exposure.scale");
  r = a.next(1.0, -1, false);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "fps");
  EXPECT_FALSE(validate(adapting(-1, 1)).ok());
  EXPECT_EQ(validate(adapting(1, NAN)).error().field, "exposure.adaptation_darken_time_s");
}

TEST(ExposureAdaptation, SettingsFromExposureSettings) {
  exposure::Settings s;
  s.adaptation_time_s = 0.5;
  s.adaptation_darken_time_s = 0.1;
  const AdaptationSettings a = adaptation_settings(s);
  EXPECT_EQ(a.brighten_time_s, 0.5);
  EXPECT_EQ(a.darken_time_s, 0.1);
}

// ---- histograms ------------------------------------------------------------------------

std::vector<float> lognormal(std::mt19937& rng, std::size_t n, double median_nits, double sigma_stops) {
  std::normal_distribution<double> stops(0.0, sigma_stops);
  std::vector<float> v(n);
  for (auto& x : v) x = static_cast<float>(median_nits * std::exp2(stops(rng)));
  return v;
}

TEST(LuminanceHistogram, PercentilesWithinOneBinOfTheSortedSamples) {
  std::mt19937 rng(7);
  auto v = lognormal(rng, 100000, 50.0, 3.0);
  const auto h = LuminanceHistogram::of(v);
  std::sort(v.begin(), v.end());
  for (double p : {1.0, 10.0, 50.0, 90.0, 99.0, 99.99}) {
    const double exact = v[static_cast<std::size_t>(p / 100 * (v.size() - 1))];
    EXPECT_NEAR(std::log2(h.percentile(p)), std::log2(exact), 1.0 / 11) << p;
  }
}

TEST(LuminanceHistogram, EdgesNonFiniteAndBlack) {
  EXPECT_DOUBLE_EQ(LuminanceHistogram::lower_edge(1), std::ldexp(1.0, LuminanceHistogram::kMinLog2Nits));
  EXPECT_DOUBLE_EQ(LuminanceHistogram::lower_edge(1 + 8 * 20 + 4), 1.5);  // 2^0 * (1 + 4/8)
  const std::vector<float> v{NAN, INFINITY, -INFINITY, -3.0f, 0.0f, 1.5f, 1.6f};
  const auto h = LuminanceHistogram::of(v);
  EXPECT_EQ(h.total(), 4u);
  EXPECT_EQ(h.counts()[0], 2u);  // -3 and 0 are black
  EXPECT_EQ(h.counts()[1 + 8 * 20 + 4], 2u);
  EXPECT_EQ(h.percentile(10), 0.0);
  EXPECT_GE(h.percentile(100), 1.5);
  EXPECT_LE(h.percentile(100), 1.625);
  EXPECT_EQ(LuminanceHistogram{}.percentile(50), 0.0);
}

TEST(LuminanceHistogram, DistanceOfAShiftIsTheShiftInStops) {
  std::mt19937 rng(3);
  const auto v = lognormal(rng, 20000, 10, 2);
  std::vector<float> up3 = v, up_half = v;
  for (auto& x : up3) x *= 8.0f;                                 // three stops, whole octaves: exact
  for (auto& x : up_half) x *= static_cast<float>(std::sqrt(2.0));  // half a stop: within a bin
  const auto a = LuminanceHistogram::of(v);
  EXPECT_EQ(histogram_distance_stops(a, a), 0.0);
  EXPECT_NEAR(histogram_distance_stops(a, LuminanceHistogram::of(up3)), 3.0, 1e-9);
  EXPECT_NEAR(histogram_distance_stops(a, LuminanceHistogram::of(up_half)), 0.5, 1.0 / 8);
  EXPECT_EQ(histogram_distance_stops(a, LuminanceHistogram{}), kNoPictureStops);
  EXPECT_EQ(histogram_distance_stops(LuminanceHistogram{}, LuminanceHistogram{}), 0.0);
  // Going black weighs as a fall to the floor (2^-14 cd/m2), not to the histogram's bottom.
  std::vector<float> one_pct_black = v;
  for (std::size_t i = 0; i < v.size() / 100; ++i) one_pct_black[i] = 0.0f;
  EXPECT_LT(histogram_distance_stops(a, LuminanceHistogram::of(one_pct_black)), 0.01 * (std::log2(10.0) + 14 + 3));
}

// ---- scene cuts on synthetic sequences --------------------------------------------------

// A procedural HDR "world" wider than the frame: a lognormal texture with a bright sky band.
struct World {
  int width = 1024, height = 96;
  std::vector<float> nits;
  explicit World(std::uint32_t seed, double median_nits) : nits(static_cast<std::size_t>(width) * height) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, 1.5);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const double sky = y < height / 4 ? 6.0 : 0.0;  // six stops brighter
        const double wave = 2.0 * std::sin(x * 0.02) ;  // large-scale structure across the pan
        nits[static_cast<std::size_t>(y) * width + x] = static_cast<float>(median_nits * std::exp2(sky + wave + n(rng)));
      }
  }
  std::vector<float> frame(int x0, int w, double gain = 1.0) const {
    std::vector<float> f;
    for (int y = 0; y < height; ++y)
      for (int x = x0; x < x0 + w; ++x) f.push_back(static_cast<float>(nits[static_cast<std::size_t>(y) * width + x] * gain));
    return f;
  }
};

std::vector<bool> cuts_of(const std::vector<std::vector<float>>& frames, std::vector<double>* distances = nullptr) {
  SceneCutDetector d;
  std::vector<bool> cuts;
  for (const auto& f : frames) {
    cuts.push_back(d.next(LuminanceHistogram::of(f)));
    if (distances) distances->push_back(d.last_distance());
  }
  return cuts;
}

TEST(SceneCut, NoCutsInAPanARampOrNoise) {
  const World w(11, 40.0);
  std::vector<std::vector<float>> pan, ramp, noisy;
  for (int i = 0; i < 120; ++i) pan.push_back(w.frame(i * 4, 256));                         // 4 px / frame
  for (int i = 0; i < 60; ++i) ramp.push_back(w.frame(100, 256, std::exp2(i * 0.1)));        // 0.1 stop / frame
  std::mt19937 rng(5);
  std::normal_distribution<double> grain(0, 0.05);
  for (int i = 0; i < 60; ++i) {
    auto f = w.frame(300, 256);
    for (auto& x : f) x = static_cast<float>(x * (1 + grain(rng)));                           // 5 % render noise
    noisy.push_back(std::move(f));
  }
  for (const auto* seq : {&pan, &ramp, &noisy}) {
    std::vector<double> dist;
    const auto cuts = cuts_of(*seq, &dist);
    EXPECT_TRUE(cuts[0]);
    for (std::size_t i = 1; i < cuts.size(); ++i) {
      EXPECT_FALSE(cuts[i]) << "frame " << i << " distance " << dist[i];
      EXPECT_LT(dist[i], 0.25) << "frame " << i;
    }
  }
}

TEST(SceneCut, CutsBetweenDifferentLightAreFoundWhereTheyAre) {
  const World interior(1, 15.0), exterior(2, 4000.0), dusk(3, 300.0);
  std::vector<std::vector<float>> seq;
  const std::vector<std::pair<const World*, int>> shots{{&interior, 12}, {&exterior, 9}, {&dusk, 7}, {&interior, 5}};
  std::vector<bool> expected;
  for (auto [world, n] : shots)
    for (int i = 0; i < n; ++i) {
      seq.push_back(world->frame(i * 3, 256));
      expected.push_back(i == 0);
    }
  std::vector<double> dist;
  EXPECT_EQ(cuts_of(seq, &dist), expected);
  for (std::size_t i = 1; i < seq.size(); ++i)
    if (expected[i]) {
      EXPECT_GT(dist[i], 3.0) << "cut at frame " << i;
    }
}

TEST(SceneCut, ThresholdIsValidated) {
  EXPECT_FALSE(validate(SceneCutSettings{0.0}).ok());
  EXPECT_FALSE(validate(SceneCutSettings{NAN}).ok());
  EXPECT_EQ(validate(SceneCutSettings{40}).error().field, "sequence.scene_cut_threshold_stops");
  EXPECT_TRUE(validate(SceneCutSettings{1.0}).ok());
}

// ---- peak detection --------------------------------------------------------------------

TEST(PeakDetector, StaticSceneIsStableAndCutResetsToTheFramesOwnPercentile) {
  std::mt19937 rng(9);
  const auto a = LuminanceHistogram::of(lognormal(rng, 20000, 20, 2));
  const auto b = LuminanceHistogram::of(lognormal(rng, 20000, 2000, 2));
  PeakDetector p;
  const double first = *p.next(a, 0.01, 0.04, true);
  EXPECT_DOUBLE_EQ(first, a.percentile(99.99) * 0.01);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(*p.next(a, 0.01, 0.04, false), first);
  EXPECT_DOUBLE_EQ(*p.next(b, 1e-4, 0.04, true), b.percentile(99.99) * 1e-4);
}

TEST(PeakDetector, RisesWithTheRiseTimeAndFallsWithTheFallTime) {
  std::mt19937 rng(4);
  const auto dim = LuminanceHistogram::of(lognormal(rng, 20000, 10, 1));
  const auto bright = LuminanceHistogram::of(lognormal(rng, 20000, 80, 1));  // 3 stops up, no cut given
  PeakDetectionSettings s;
  PeakDetector p(s);
  const double dt = 1.0 / 24;
  const double lo = *p.next(dim, 1.0, dt, true), hi = bright.percentile(s.percentile);
  for (int k = 1; k <= 24; ++k)
    EXPECT_NEAR(std::log2(*p.next(bright, 1.0, dt, false)), model_stops(lo, hi, s.rise_time_s, k * dt), 1e-12);
  const double top = *p.next(bright, 1.0, 0, false);
  for (int k = 1; k <= 24; ++k)
    EXPECT_NEAR(std::log2(*p.next(dim, 1.0, dt, false)), model_stops(top, lo, s.fall_time_s, k * dt), 1e-12);
}

TEST(PeakDetector, BlackFrameStaysFinite) {
  PeakDetector p;
  const std::vector<float> black(100, 0.0f);
  const double v = *p.next(LuminanceHistogram::of(black), 1.0, 0.04, true);
  EXPECT_GT(v, 0);
  EXPECT_TRUE(std::isfinite(v));
  EXPECT_FALSE(validate(PeakDetectionSettings{40, 1, 1}).ok());
}

// ---- the whole time axis --------------------------------------------------------------

TEST(TemporalTone, FirstFrameOfEachSceneIsExposedAsASingleFrame) {
  exposure::Settings e;
  e.mode = exposure::Mode::histogram;
  e.adaptation_time_s = 1.0;
  TemporalSettings t;
  t.adaptation = adaptation_settings(e);
  TemporalTone tone(t);
  const World interior(1, 15.0), exterior(2, 4000.0);
  for (int i = 0; i < 30; ++i) {
    const bool second_shot = i >= 15;
    const auto f = (second_shot ? exterior : interior).frame(i * 2, 200);
    const auto d = *tone.next(f, e, 203, 1.0 / 24);
    const double single = exposure::meter(e, f, 203)->scale;
    EXPECT_EQ(d.scene_start, i == 0 || i == 15) << i;
    if (d.scene_start) {
      EXPECT_EQ(d.exposure_scale, single) << i;
    } else if (i > 16) {
      EXPECT_NEAR(std::log2(d.exposure_scale), std::log2(single), 0.5) << i;  // a pan: close to it
    }
  }
}

TEST(TemporalTone, ManualExposureIsEveryFramesSingleFrameExposure) {
  exposure::Settings e;
  e.compensation_ev = 0.5;
  e.adaptation_time_s = 2.0;
  TemporalTone tone(TemporalSettings{adaptation_settings(e), {}, {}, true});
  const World w(5, 100.0);
  const double single = exposure::meter(e, {}, 203)->scale;
  for (int i = 0; i < 40; ++i) EXPECT_EQ(tone.next(w.frame(i * 7, 128, std::exp2(i % 5)), e, 203, 0.04)->exposure_scale, single);
}

TEST(TemporalTone, GivenCutsAloneWhenDetectionIsOff) {
  exposure::Settings e;
  TemporalSettings t;
  t.detect_cuts = false;
  TemporalTone tone(t);
  const World a(1, 10.0), b(2, 5000.0);
  EXPECT_TRUE(tone.next(a.frame(0, 64), e, 203, 0.04)->scene_start);
  EXPECT_FALSE(tone.next(b.frame(0, 64), e, 203, 0.04)->scene_start);
  EXPECT_TRUE(tone.next(b.frame(0, 64), e, 203, 0.04, true)->scene_start);
}


// The scene average (curves with a knee on it: spline, st2094-40, st2094-10): the mean of the
// frame's luminance times its exposure, smoothed in stops with the peak's time constants and
// taken as it is on the first frame of a scene.
TEST(TemporalTone, SceneAverageIsTheSmoothedExposedMean) {
  exposure::Settings e;  // manual: the scale exposure::meter gives
  TemporalSettings t;
  t.detect_cuts = false;
  TemporalTone tone(t);
  const double scale = exposure::meter(e, {}, 203)->scale;
  auto mean = [](const std::vector<float>& v) {
    double s = 0;
    for (float x : v) s += x;
    return s / static_cast<double>(v.size());
  };
  const std::vector<float> dim(1000, 20.0f), bright(1000, 320.0f);  // four stops apart
  const auto first = *tone.next(dim, e, 203, 1.0 / 24);
  EXPECT_NEAR(first.source_average, mean(dim) * scale, 1e-12 * mean(dim) * scale);
  // A step up of four stops approaches with the rise time (0.25 s): after 0.25 s, 1 - 1/e of it.
  double got = 0;
  for (int i = 0; i < 6; ++i) got = tone.next(bright, e, 203, 1.0 / 24)->source_average;
  const double want_stops = 4 * (1 - std::exp(-0.25 / 0.25));
  EXPECT_NEAR(std::log2(got / (mean(dim) * scale)), want_stops, 1e-9);
  // A cut takes the new scene's mean as it is.
  const auto cut = *tone.next(dim, e, 203, 1.0 / 24, true);
  EXPECT_NEAR(cut.source_average, mean(dim) * scale, 1e-12 * mean(dim) * scale);
  // A black frame stays finite and positive.
  EXPECT_GT(tone.next(std::vector<float>(10, 0.0f), e, 203, 1.0 / 24, true)->source_average, 0.0);
}

}  // namespace

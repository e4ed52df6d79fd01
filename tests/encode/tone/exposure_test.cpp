// Exposure modes as REFERENCE.md §1.2 defines them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "encode/tone/exposure.hpp"

using namespace hdrd::exposure;

namespace {

TEST(Exposure, Ev100FromCameraSunny16) {
  EXPECT_NEAR(ev100_from_camera(16, 1.0 / 125, 100), 14.966, 5e-4);  // REFERENCE.md §1.2
  EXPECT_NEAR(scale_from_ev100(0), 1 / 1.2, 1e-15);
}

TEST(Exposure, ManualRelativePassesThroughAndCompensationBrightens) {
  Settings s;
  auto m = meter(s, {}, 203);
  ASSERT_TRUE(m.ok());
  EXPECT_DOUBLE_EQ(m->scale * 203, 1.0);  // relative v -> v * 203 nits -> v
  s.compensation_ev = 1;
  EXPECT_DOUBLE_EQ(meter(s, {}, 203)->scale * 203, 2.0);
  s.compensation_ev = -2;
  EXPECT_DOUBLE_EQ(meter(s, {}, 203)->scale * 203, 0.25);
}

TEST(Exposure, CameraModeUsesEv100) {
  Settings s;
  s.mode = Mode::camera;
  s.ev100 = 15;
  EXPECT_DOUBLE_EQ(meter(s, {}, 203)->scale, 1.0 / (1.2 * std::exp2(15)));
}

TEST(Exposure, LogAverageMapsKeyToMidGrey) {
  Settings s;
  s.mode = Mode::log_average;
  std::vector<float> l(1000, 50.0f);
  auto m = meter(s, l, 203);
  ASSERT_TRUE(m.ok());
  EXPECT_NEAR(m->scale * 50.0, 0.18, 1e-3);  // eps is tiny relative to 50 nits
}

TEST(Exposure, HistogramMedianIsRobustToAFewBrightPixels) {
  Settings s;
  s.mode = Mode::histogram;
  s.percentile = 50;  // Valve's median of the window [0, 98 %]
  s.ignore_dark_fraction = 0;
  s.ignore_bright_fraction = 0.02;
  std::vector<float> l(10000, 10.0f);
  for (int i = 0; i < 100; ++i) l[i] = 1e6f;  // 1 % very bright
  for (int i = 100; i < 200; ++i) l[i] = NAN;  // ignored
  auto m = meter(s, l, 203);
  ASSERT_TRUE(m.ok());
  EXPECT_NEAR(std::log2(m->scale * 10.0 / 0.18), 0, 1.0 / 8);  // within its 1/8-stop histogram bin
  // 95th percentile to 0.9, ignoring the brightest 2 %.
  for (int i = 0; i < 5000; ++i) l[200 + i] = 20.0f;
  s.percentile = 95;
  s.percentile_target = 0.9;
  m = meter(s, l, 203);
  EXPECT_NEAR(std::log2(m->scale * 20.0 / 0.9), 0, 1.0 / 8);
}

// Unreal's histogram exposure (the defaults: window [80 %, 98.3 %], averaged in stops). A
// room whose luminance spreads log-uniformly over 25-100 cd/m2 (~50) and a sun covering 2 %
// of the frame at 1e6 cd/m2: the room sets the exposure. The reference is computed here by
// sorting the samples and averaging log2 over the window exactly.
TEST(Exposure, HistogramWindowIgnoresATinyVeryBrightRegion) {
  const int n = 20000, sun = n / 50;
  std::vector<float> l;
  for (int i = 0; i < n - sun; ++i) l.push_back(static_cast<float>(25.0 * std::exp2(2.0 * (i + 0.5) / (n - sun))));
  for (int i = 0; i < sun; ++i) l.push_back(1e6f);
  std::vector<float> sorted = l;
  std::sort(sorted.begin(), sorted.end());
  double sum = 0;
  const int lo = static_cast<int>(0.80 * n), hi = static_cast<int>(0.983 * n);
  for (int i = lo; i < hi; ++i) sum += std::log2(sorted[static_cast<std::size_t>(i)]);
  const double window_nits = std::exp2(sum / (hi - lo));
  Settings s;
  s.mode = Mode::histogram;
  auto m = meter(s, l, 203);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_NEAR(std::log2(m->scale * window_nits / 0.18), 0, 1.0 / 16) << "the window's average in stops -> 0.18";
  // The sun (0.3 % of the frame inside the window's top: 0.22 stop) moves the exposure by
  // less than 0.3 stop from the room's own window: the room's brightest 18 % set it.
  double room_sum = 0;
  for (int i = lo; i < hi; ++i) room_sum += std::log2(sorted[static_cast<std::size_t>(std::min(i, n - sun - 1))]);
  EXPECT_NEAR(std::log2(m->scale * std::exp2(room_sum / (hi - lo)) / 0.18), 0, 0.3);
  // Ten times the sun changes nothing but its 0.3 % share.
  for (int i = n - sun; i < n; ++i) l[static_cast<std::size_t>(i)] = 1e7f;
  EXPECT_NEAR(std::log2(meter(s, l, 203)->scale / m->scale), 0, 0.02 * std::log2(10.0) + 1.0 / 16);
}

// Unreal's min/max EV100: a metered exposure is that of a camera whose EV100 stays within
// the range (EV100 of scale k: 1 / (1.2 * 2^EV100) = k, Lagarde & de Rousiers 2014).
TEST(Exposure, MeteredExposureIsClampedToTheEv100Range) {
  Settings s;
  s.mode = Mode::histogram;
  s.min_ev100 = -6;
  s.max_ev100 = 16;
  const std::vector<float> night(1000, 1e-3f), sun(1000, 1e7f), room(1000, 50.0f);
  // 1e-3 cd/m2 -> 0.18 would need EV100 log2(1e-3 / (1.2 * 0.18)) = -7.8: held at -6.
  EXPECT_DOUBLE_EQ(meter(s, night, 203)->scale, 1.0 / (1.2 * std::exp2(-6.0)));
  EXPECT_DOUBLE_EQ(*meter(s, night, 203)->ev100, -6.0);
  EXPECT_DOUBLE_EQ(meter(s, sun, 203)->scale, 1.0 / (1.2 * std::exp2(16.0)));
  // Inside the range: untouched (50 cd/m2 -> 0.18 is EV100 7.9).
  EXPECT_NEAR(std::log2(meter(s, room, 203)->scale * 50.0 / 0.18), 0, 1.0 / 16);
  // The compensation applies after the clamp, and log-average is clamped the same way.
  s.compensation_ev = 1;
  EXPECT_DOUBLE_EQ(meter(s, night, 203)->scale, 2.0 / (1.2 * std::exp2(-6.0)));
  s.mode = Mode::log_average;
  EXPECT_DOUBLE_EQ(meter(s, sun, 203)->scale, 2.0 / (1.2 * std::exp2(16.0)));
  s.min_ev100 = 17;
  auto bad = meter(s, room, 203);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "exposure.min_ev100");
}

TEST(Exposure, LightBasedWhiteCardIsOne) {
  Settings s;
  s.mode = Mode::light;
  s.illuminance_lux = 100000;
  auto m = meter(s, {}, 203);
  ASSERT_TRUE(m.ok());
  const double white_card_nits = 100000 / std::numbers::pi;  // 31831 cd/m2
  EXPECT_NEAR(m->scale * white_card_nits, 1.0, 1e-12);
  EXPECT_NEAR(m->scale * 0.18 * white_card_nits, 0.18, 1e-12);
  s.illuminance_lux.reset();
  EXPECT_FALSE(meter(s, {}, 203).ok());
}

TEST(Exposure, InvalidSettingsNameTheField) {
  Settings s;
  s.compensation_ev = NAN;
  auto m = meter(s, {}, 203);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().field, "exposure.compensation_ev");
  Settings h;
  h.mode = Mode::histogram;
  std::vector<float> nan(10, NAN);
  EXPECT_FALSE(meter(h, nan, 203).ok());
}

}  // namespace

// Exposure modes as REFERENCE.md §1.2 defines them.
#include <gtest/gtest.h>

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
  std::vector<float> l(10000, 10.0f);
  for (int i = 0; i < 100; ++i) l[i] = 1e6f;  // 1 % very bright
  for (int i = 100; i < 200; ++i) l[i] = NAN;  // ignored
  auto m = meter(s, l, 203);
  ASSERT_TRUE(m.ok());
  EXPECT_NEAR(m->scale * 10.0, 0.18, 1e-9);
  // 95th percentile to 0.9, ignoring the brightest 2 %.
  for (int i = 0; i < 5000; ++i) l[200 + i] = 20.0f;
  s.percentile = 95;
  s.percentile_target = 0.9;
  m = meter(s, l, 203);
  EXPECT_NEAR(m->scale * 20.0, 0.9, 1e-9);
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

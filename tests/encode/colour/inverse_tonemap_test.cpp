// Inverse tone mapping of SDR content into HDR frames (ui.inverse_tonemap) against
// ITU-R BT.2446-1 method C's inverse, its equations written out here.
#include <gtest/gtest.h>

#include <cmath>

#include "encode/colour/sdr_content.hpp"

using namespace hdrd;

namespace {

// BT.2446-1 method C (in cd/m2 of a 100 cd/m2 SDR white): the inverse is
//   Y_HDR = Y_SDR / k1                                   for Y_SDR <  Y_SDR,ip
//   Y_HDR = (exp((Y_SDR - k4) / k2) + k3) * Y_HDR,ip     for Y_SDR >= Y_SDR,ip, Y_HDR,ip = Y_SDR,ip / k1
// with the Recommendation's k2 = 15.09968, k3 = 0.74204, k4 = 78.99439 and the knee Y_SDR,ip = 58.535.
// hdrd folds 1/k1 into the SDR white gain (the linear part is light * sdr_white).
constexpr double kK2 = 15.09968, kK3 = 0.74204, kK4 = 78.99439, kYsdrIp = 58.535;

double rec_inverse(double y_sdr100, double white) {
  const double hdr_ip = kYsdrIp / 100 * white;
  if (y_sdr100 < kYsdrIp) return y_sdr100 / 100 * white;
  return (std::exp((y_sdr100 - kK4) / kK2) + kK3) * hdr_ip;
}

TEST(InverseTonemap, NamesParse) {
  EXPECT_EQ(parse_inverse_tonemap("linear"), InverseTonemap::linear);
  EXPECT_EQ(parse_inverse_tonemap("bt2446c"), InverseTonemap::bt2446c);
  EXPECT_EQ(parse_inverse_tonemap("bt2446a-inverse"), InverseTonemap::bt2446c);
  EXPECT_FALSE(parse_inverse_tonemap("bt2408x"));
  EXPECT_EQ(to_string(InverseTonemap::bt2446c), "bt2446c");
}

TEST(InverseTonemap, LinearIsTheGain) {
  for (double y : {0.0, 0.01, 0.5, 1.0, 1.5})
    EXPECT_EQ(sdr_light_to_nits(InverseTonemap::linear, y, 203.0, 1000.0), y * 203.0);
}

// With the display peak where the Recommendation's own curve puts SDR's maximum, the
// peak-bounded k2 is the Recommendation's: the curve matches its equations.
TEST(InverseTonemap, Bt2446cMatchesTheRecommendation) {
  for (double white : {100.0, 203.0}) {
    const double peak = rec_inverse(100, white);
    for (int i = 0; i <= 100; ++i) {
      const double y = i / 100.0;
      const double want = rec_inverse(y * 100, white);
      EXPECT_NEAR(sdr_light_to_nits(InverseTonemap::bt2446c, y, white, peak), want, want * 2e-4 + 1e-12)
          << "y " << y << " white " << white;
    }
  }
  // The Recommendation's k2 and k4 follow from k3 and the knee (C1 at the knee, continuity).
  EXPECT_NEAR((1 - kK3) * kYsdrIp, kK2, 2e-3);
  EXPECT_NEAR(kYsdrIp - kK2 * std::log(1 - kK3), kK4, 2e-3);
}

TEST(InverseTonemap, Bt2446cMonotoneAndPeakOnlyAtOne) {
  for (double peak : {150.0, 400.0, 1000.0, 4000.0}) {
    const double white = 203.0;
    double prev = -1;
    for (int i = 0; i <= 4096; ++i) {
      const double y = i / 4096.0;
      const double nits = sdr_light_to_nits(InverseTonemap::bt2446c, y, white, peak);
      EXPECT_GE(nits, prev) << "peak " << peak << " y " << y;
      EXPECT_LE(nits, peak);
      if (i < 4096) {
        EXPECT_LT(nits, peak) << "reaches the peak before V = 1: y " << y;
      }
      prev = nits;
    }
    EXPECT_EQ(sdr_light_to_nits(InverseTonemap::bt2446c, 1.0, white, peak), peak);
    EXPECT_EQ(sdr_light_to_nits(InverseTonemap::bt2446c, 2.0, white, peak), peak);
    // Below the knee SDR light keeps its gain to SDR white (as linear).
    EXPECT_DOUBLE_EQ(sdr_light_to_nits(InverseTonemap::bt2446c, 0.5, white, peak), 0.5 * white);
  }
  // No headroom above the knee: the linear gain, clipped to the peak.
  EXPECT_DOUBLE_EQ(sdr_light_to_nits(InverseTonemap::bt2446c, 1.0, 203.0, 100.0), 100.0);
}

}  // namespace

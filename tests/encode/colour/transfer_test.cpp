// Transfer functions against published vectors: REFERENCE.md §2 and
// reference/published_vectors.md (colour-science test suites, BT.2408, BT.2100 table 9).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "encode/colour/transfer.hpp"

using namespace hdrd::transfer;

namespace {

struct PqRow {
  double nits, signal;
  int full10, narrow10;
};
// REFERENCE.md §2 table (values published in BT.2408 / derived from ST 2084 and
// cross-checked against OpenColorIO 2.1 in the platform notes).
constexpr PqRow kPqTable[] = {
    {0.005, 0.015076, 15, 77},  {0.1, 0.062337, 64, 119},   {1, 0.149946, 153, 195},
    {26, 0.380032, 389, 397},   {80, 0.485857, 497, 490},   {100, 0.508078, 520, 509},
    {203, 0.580689, 594, 573},  {400, 0.652579, 668, 636},  {1000, 0.751827, 769, 723},
    {4000, 0.902572, 923, 855}, {10000, 1.0, 1023, 940},
};

TEST(Pq, ReferenceTable) {
  for (const auto& r : kPqTable) {
    const double e = pq_inverse_eotf(r.nits);
    EXPECT_NEAR(e, r.signal, 5e-7) << r.nits << " cd/m2";
    EXPECT_EQ(quantize_full(e, 10), r.full10) << r.nits;
    EXPECT_EQ(quantize_narrow(e, 10), r.narrow10) << r.nits;
  }
}

// colour-science test_st_2084.py and test_itur_bt_2100.py (published_vectors.md §1a, §1b).
TEST(Pq, ColourSciencePublished) {
  EXPECT_NEAR(pq_inverse_eotf(0), 0.000000730955903, 1e-15);
  EXPECT_NEAR(pq_inverse_eotf(100), 0.508078421517399, 1e-13);
  EXPECT_NEAR(pq_inverse_eotf(400), 0.652578597563067, 1e-13);
  EXPECT_NEAR(pq_eotf(0.508078421517399), 100, 1e-9);
  EXPECT_NEAR(pq_eotf(0.652578597563067), 400, 1e-9);
  EXPECT_NEAR(pq_eotf(0.724769816665726), 779.98836083408537, 1e-8);
  EXPECT_NEAR(pq_inverse_eotf(779.98836083408537), 0.724769816665726, 1e-13);
  EXPECT_NEAR(pq_eotf(1.0), 10000, 1e-9);
}

// SMPTE presentation table (published_vectors.md §2): 0.5805 -> 202.63 (colorjs).
TEST(Pq, Bt2408Levels) {
  EXPECT_NEAR(pq_eotf(0.3800), 25.99, 0.01);
  EXPECT_NEAR(pq_eotf(0.5575), 162.41, 0.01);
  EXPECT_NEAR(pq_eotf(0.5805), 202.63, 0.01);
}

TEST(Pq, RoundTripAndMonotonic) {
  double prev = -1;
  for (double lg = -6; lg <= 4; lg += 0.01) {
    const double nits = std::pow(10.0, lg);
    const double e = pq_inverse_eotf(nits);
    EXPECT_GT(e, prev);
    prev = e;
    EXPECT_NEAR(pq_eotf(e) / nits, 1.0, 1e-9) << nits;
  }
  EXPECT_EQ(pq_inverse_eotf(-5.0), pq_inverse_eotf(0.0));  // negatives clamp to black
}

TEST(Pq, FastApproximationErrorIsAsStated) {
  double worst = 0;
  for (double lg = -4; lg <= 4; lg += 0.0003) {
    const double nits = std::pow(10.0, lg);
    worst = std::max(worst, std::abs(pq_inverse_eotf_fast(nits) - pq_inverse_eotf(nits)));
  }
  EXPECT_LT(worst, kPqFastMaxError);
  EXPECT_GT(worst, 0.0);  // it is an approximation, not a copy of the exact path
}

// published_vectors.md §1b.
TEST(Hlg, ColourSciencePublished) {
  EXPECT_NEAR(hlg_oetf(0.18 / 12), 0.212132034355964, 1e-14);
  EXPECT_NEAR(hlg_oetf(1.0), 0.999999995536569, 1e-12);
  EXPECT_NEAR(hlg_system_gamma(1000), 1.2, 1e-15);
  EXPECT_NEAR(hlg_system_gamma(2000), 1.326432598178872, 1e-12);
  // (colour-science's gamma_function_HLG_BT2100 keeps 1.2 + 0.42 log10(Lw / 1000) beyond
  // 2000 cd/m2, 1.4529 at 4000 and 1.62 at 10000; BT.2100 note 5f says otherwise: below.)
  // eotf_BT2100_HLG_1(0.212132034355964), achromatic, Lw = 1000.
  const double s = 0.212132034355964;
  EXPECT_NEAR(hlg_eotf({s, s, s}, 1000).y, 6.476039825649814, 1e-9);
  EXPECT_NEAR(hlg_eotf({1, 1, 1}, 1000).x, 1000.000032321769100, 1e-5);  // 3e-9 relative
  // RGB triplet: the OOTF uses the scene luminance of all three channels.
  const auto fd = hlg_eotf({0.25, 0.50, 0.75}, 1000);
  EXPECT_NEAR(fd.x, 12.49759413, 1e-6);
  EXPECT_NEAR(fd.y, 49.99037650, 1e-6);
  EXPECT_NEAR(fd.z, 158.94693786, 1e-6);
}

// BT.2100-2 Table 5 note 5f: 1.2 + 0.42 log10(Lw / 1000) over 400 <= Lw <= 2000 cd/m2, the
// extended range formula 1.2 x 1.111^log2(Lw / 1000) outside it (BT.2390 §6.2 likewise),
// both written out here.
TEST(Hlg, SystemGammaAtAndBeyondTheProductionRange) {
  auto in_range = [](double lw) { return 1.2 + 0.42 * std::log10(lw / 1000); };
  auto extended = [](double lw) { return 1.2 * std::pow(1.111, std::log2(lw / 1000)); };
  EXPECT_DOUBLE_EQ(hlg_system_gamma(1000), 1.2);
  EXPECT_NEAR(hlg_system_gamma(2000), in_range(2000), 1e-15);
  EXPECT_NEAR(hlg_system_gamma(400), in_range(400), 1e-15);
  EXPECT_NEAR(hlg_system_gamma(4000), extended(4000), 1e-15);
  EXPECT_NEAR(hlg_system_gamma(10000), extended(10000), 1e-15);
  EXPECT_NEAR(hlg_system_gamma(100), extended(100), 1e-15);
  // The numbers: 4000 -> 1.2 x 1.111^2 = 1.4811852, 10000 -> 1.7023 (not 1.4529 and 1.62).
  EXPECT_NEAR(hlg_system_gamma(4000), 1.4811852, 1e-7);
  EXPECT_NEAR(hlg_system_gamma(10000), 1.70233, 1e-4);
  EXPECT_NEAR(hlg_system_gamma(2000), 1.32643, 1e-5);
}

// BT.2100 Table 5 with a black level: F_D = OOTF[OETF^-1[max(0, (1 - beta) E' + beta)]],
// beta = sqrt(3 (Lb / Lw)^(1 / gamma)). Written out here for grey (F_D = Lw E^gamma) and
// inverted by hand: E' = (OETF((F_D / Lw)^(1 / gamma)) - beta) / (1 - beta).
TEST(Hlg, BlackLevelLiftAndItsInverse) {
  const double a = 0.17883277, b = 1 - 4 * a, c = 0.55991073;  // as BT.2100 Table 5 publishes them
  auto oetf = [&](double e) { return e <= 1.0 / 12 ? std::sqrt(3 * e) : a * std::log(12 * e - b) + c; };
  for (double lw : {600.0, 1000.0, 4000.0})
    for (double lb : {0.0, 0.005, 0.05, 0.5}) {
      const double g = lw <= 2000 && lw >= 400 ? 1.2 + 0.42 * std::log10(lw / 1000)
                                               : 1.2 * std::pow(1.111, std::log2(lw / 1000));
      const double beta = std::sqrt(3 * std::pow(lb / lw, 1 / g));
      const auto d = HlgDisplay::from_levels(lw, lb);
      EXPECT_NEAR(d.beta, beta, 1e-15);
      // E' = 0 shows the black level, E' = 1 the peak.
      EXPECT_NEAR(hlg_eotf({0, 0, 0}, lw, lb).y, lb, 1e-12 * lw);
      EXPECT_NEAR(hlg_eotf({1, 1, 1}, lw, lb).y, lw, 1e-5 * lw);
      for (double nits : {lb, lb * 1.5 + 1e-3, 1.0, 26.0, 203.0, 0.5 * lw, lw}) {
        const double want = std::clamp((oetf(std::pow(nits / lw, 1 / g)) - beta) / (1 - beta), 0.0, 1.0);
        EXPECT_NEAR(hlg_inverse_eotf({nits, nits, nits}, lw, lb).y, want, 1e-12) << lw << " " << lb << " " << nits;
        if (nits >= lb) {
          EXPECT_NEAR(hlg_eotf({want, want, want}, lw, lb).y, nits, 1e-9 * lw) << nits;
        }
      }
      // Below the black level there is no signal: E' = 0.
      if (lb > 0) {
        EXPECT_EQ(hlg_inverse_eotf({lb * 0.5, lb * 0.5, lb * 0.5}, lw, lb).x, 0.0);
      }
    }
}

TEST(Hlg, ReferenceWhiteAt75Percent) {
  // BT.2408: 203 cd/m2 is 75 % HLG on a 1000 cd/m2 display.
  const auto s = hlg_inverse_eotf({203, 203, 203}, 1000);
  EXPECT_NEAR(s.x, 0.75, 0.001);
  EXPECT_NEAR(hlg_eotf({0.75, 0.75, 0.75}, 1000).x, 203.15, 0.05);
}

TEST(Hlg, InverseRoundTrips) {
  for (double peak : {400.0, 1000.0, 2000.0, 4000.0}) {
    for (const hdrd::color::Vec3 e : {hdrd::color::Vec3{0.25, 0.5, 0.75}, {0.9, 0.1, 0.3}, {0.6, 0.6, 0.6}}) {
      const auto back = hlg_inverse_eotf(hlg_eotf(e, peak), peak);
      EXPECT_NEAR(back.x, e.x, 1e-9);
      EXPECT_NEAR(back.y, e.y, 1e-9);
      EXPECT_NEAR(back.z, e.z, 1e-9);
    }
  }
}

TEST(Srgb, Piecewise) {
  EXPECT_NEAR(srgb_inverse_eotf(0.18), 0.4614, 1e-4);  // REFERENCE.md §2
  EXPECT_NEAR(srgb_eotf(136.0 / 255.0), 0.24620132670783548, 1e-15);  // published_vectors.md §4
  EXPECT_DOUBLE_EQ(srgb_inverse_eotf(0.0031308), 12.92 * 0.0031308);
  for (double v = 0; v <= 1.0; v += 0.001) EXPECT_NEAR(srgb_inverse_eotf(srgb_eotf(v)), v, 1e-12);
}

TEST(Bt1886, LevelsAndRoundTrip) {
  const auto c = Bt1886::from_levels(100, 0.1);
  EXPECT_NEAR(c.eotf(1.0), 100, 1e-9);
  EXPECT_NEAR(c.eotf(0.0), 0.1, 1e-9);
  for (double v = 0; v <= 1.0; v += 0.01) EXPECT_NEAR(c.inverse_eotf(c.eotf(v)), v, 1e-12);
  // With Lb = 0 it is a pure 2.4 power law.
  const auto z = Bt1886::from_levels(100, 0);
  EXPECT_NEAR(z.eotf(0.5), 100 * std::pow(0.5, 2.4), 1e-9);
}

TEST(Quantize, NarrowRangeTable9) {
  // BT.2100 table 9: black 64 / 256, nominal peak 940 / 3760.
  EXPECT_EQ(quantize_narrow(0.0, 10), 64);
  EXPECT_EQ(quantize_narrow(1.0, 10), 940);
  EXPECT_EQ(quantize_narrow(0.0, 12), 256);
  EXPECT_EQ(quantize_narrow(1.0, 12), 3760);
  EXPECT_NEAR(dequantize_narrow(quantize_narrow(0.5, 10), 10), 0.5, 1.0 / 876);
}

}  // namespace

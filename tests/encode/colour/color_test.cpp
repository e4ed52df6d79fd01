// Colour spaces: matrices derived from chromaticities vs published matrices, and ICtCp
// vs the colour-science vectors (published_vectors.md §1c).
#include <gtest/gtest.h>

#include "encode/colour/color.hpp"
#include "encode/colour/transfer.hpp"

using namespace hdrd::color;

namespace {

void expect_matrix_near(const Mat3& a, const Mat3& b, double tol) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.m[i][j], b.m[i][j], tol) << i << "," << j;
}

TEST(Matrices, Rec709ToRec2020MatchesBt2087) {
  expect_matrix_near(rgb_to_rgb(kRec709, kRec2020), kBt2087Rec709ToRec2020, 5e-5);
}

TEST(Matrices, LuminanceRowsMatchBt709AndBt2020) {
  const Vec3 y709 = luminance_weights(kRec709), y2020 = luminance_weights(kRec2020);
  EXPECT_NEAR(y709.x, 0.2126, 5e-5);
  EXPECT_NEAR(y709.y, 0.7152, 5e-5);
  EXPECT_NEAR(y709.z, 0.0722, 5e-5);
  EXPECT_NEAR(y2020.x, 0.2627, 5e-5);
  EXPECT_NEAR(y2020.y, 0.6780, 5e-5);
  EXPECT_NEAR(y2020.z, 0.0593, 5e-5);
}

TEST(Matrices, Rec709ToXyzMatchesIec61966) {
  // IEC 61966-2-1 (sRGB) published matrix, 4 decimals.
  const Mat3 published{{{{0.4124, 0.3576, 0.1805}, {0.2126, 0.7152, 0.0722}, {0.0193, 0.1192, 0.9505}}}};
  expect_matrix_near(rgb_to_xyz(kRec709), published, 1e-4);
}

TEST(Matrices, WhiteMapsToWhiteAndInverseRoundTrips) {
  for (const auto& s : spaces()) {
    if (s.space == Space::xyz) continue;
    const Vec3 w = rgb_to_xyz(s.primaries) * Vec3{1, 1, 1};
    const Vec3 ref = xy_to_XYZ(s.primaries.white);
    EXPECT_NEAR(w.x, ref.x, 1e-12) << s.name;
    EXPECT_NEAR(w.y, 1.0, 1e-12) << s.name;
    const Mat3 id = xyz_to_rgb(s.primaries) * rgb_to_xyz(s.primaries);
    expect_matrix_near(id, Mat3::identity(), 1e-12);
  }
}

TEST(Matrices, AcesAdaptedToD65KeepsWhite) {
  const Vec3 w = to_working(Space::aces_ap0) * Vec3{1, 1, 1};
  EXPECT_NEAR(w.x, 1.0, 1e-9);
  EXPECT_NEAR(w.y, 1.0, 1e-9);
  EXPECT_NEAR(w.z, 1.0, 1e-9);
}

TEST(Spaces, FindByNameAndAlias) {
  EXPECT_EQ(find_space("rec2020"), Space::rec2020);
  EXPECT_EQ(find_space("sRGB"), Space::rec709);
  EXPECT_EQ(find_space("ACEScg"), Space::aces_ap1);
  EXPECT_FALSE(find_space("nonsense").has_value());
}

// colour-science test_ictcp.py: inputs are absolute cd/m2 Rec.2020 (L_p scales them).
TEST(Ictcp, ColourSciencePublished) {
  const Vec3 rgb{0.45620519, 0.03081071, 0.04091952};
  auto check = [](Vec3 got, Vec3 want) {
    EXPECT_NEAR(got.x, want.x, 2e-8);
    EXPECT_NEAR(got.y, want.y, 2e-8);
    EXPECT_NEAR(got.z, want.z, 2e-8);
  };
  check(rec2020_nits_to_ictcp(rgb), {0.07351364, 0.00475253, 0.09351596});
  check(rec2020_nits_to_ictcp(rgb * 2.5), {0.10516931, 0.00514031, 0.12318730});
  check(rec2020_nits_to_ictcp(rgb * 10.0), {0.17079612, 0.00485580, 0.17431356});
  // XYZ input: XYZ -> Rec.2020 first.
  const Vec3 xyz{0.20654008, 0.12197225, 0.05136952};
  check(rec2020_nits_to_ictcp(xyz_to_rgb(kRec2020) * xyz), {0.06858097, -0.00283842, 0.06020983});
  check(rec2020_nits_to_ictcp(xyz_to_rgb(kRec2020) * (xyz * 10.0)), {0.16173872, -0.00792543, 0.11409458});
}

TEST(Ictcp, RoundTrip) {
  for (const Vec3 c : {Vec3{100, 50, 20}, Vec3{0.01, 0.02, 0.5}, Vec3{1000, 1000, 1000}}) {
    const Vec3 back = ictcp_to_rec2020_nits(rec2020_nits_to_ictcp(c));
    EXPECT_NEAR(back.x / c.x, 1.0, 1e-9);
    EXPECT_NEAR(back.y / c.y, 1.0, 1e-9);
    EXPECT_NEAR(back.z / c.z, 1.0, 1e-9);
  }
  // Achromatic input has Ct = Cp = 0 (D65 white).
  const Vec3 grey = rec2020_nits_to_ictcp({203, 203, 203});
  EXPECT_NEAR(grey.y, 0.0, 1e-6);
  EXPECT_NEAR(grey.z, 0.0, 1e-6);
}

}  // namespace

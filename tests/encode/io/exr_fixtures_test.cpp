// Every fixture EXR loads with the statistics OpenImageIO's oiiotool measured
// (../shared/fixtures/exr/reference_stats.json), and the Rec709/XYZ pair agrees in the
// working space (published_vectors.md §5).
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

using nlohmann::json;

struct ChannelStats {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  long double sum = 0;       // extended precision: our own sum is not the thing under test
  long double abs_sum = 0;
  long long nan = 0, inf = 0, finite = 0;
};

// Which of our RGBA slots holds the file's channel: Y and lone channels are replicated
// to grey, so slot 0 (and 1, 2) carry them.
int slot_of(const std::string& channel, int nchannels) {
  if (nchannels == 1) return 0;
  if (channel == "R") return 0;
  if (channel == "G") return 1;
  if (channel == "B") return 2;
  if (channel == "A") return 3;
  return -1;
}

ChannelStats stats_of(const Image& img, int slot) {
  ChannelStats s;
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const double v = img.rgba[i * 4 + static_cast<std::size_t>(slot)];
    if (std::isnan(v)) { ++s.nan; continue; }
    if (std::isinf(v)) { ++s.inf; continue; }
    ++s.finite;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
    s.sum += v;
    s.abs_sum += std::abs(v);
  }
  return s;
}

// The JSON prints 6 decimals for min/max/avg; probes as float32 with up to 9 digits.
double printed_tolerance(double ref) { return 1e-6 + 1e-6 * std::abs(ref); }

// The reference average came from a double-precision sum over the channel (oiiotool);
// a naive sum of n terms is off by up to n * 2^-53 * sum|x| (Higham, Accuracy and
// Stability, eq. 4.4), which matters only for WideFloatRange's +-1.7e38 values.
double average_tolerance(double ref, const ChannelStats& s) {
  const double n = static_cast<double>(s.finite);
  const double summation = n * std::ldexp(1.0, -53) * static_cast<double>(s.abs_sum) / std::max(n, 1.0);
  return printed_tolerance(ref) + summation;
}

double probe_value(const json& v) {
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s == "nan") return std::numeric_limits<double>::quiet_NaN();
    if (s == "inf") return std::numeric_limits<double>::infinity();
    if (s == "-inf") return -std::numeric_limits<double>::infinity();
    ADD_FAILURE() << "unexpected probe string " << s;
  }
  return v.get<double>();
}

void expect_probe(double ours, double ref, const std::string& where) {
  if (std::isnan(ref)) {
    EXPECT_TRUE(std::isnan(ours)) << where;
  } else if (std::isinf(ref)) {
    EXPECT_EQ(ours, ref) << where;
  } else {
    // "-7.629e-06" is printed with 4 digits; halves are 2^-11 apart relatively, so
    // 2e-4 still tells neighbouring half values apart.
    EXPECT_NEAR(ours, ref, 1e-9 + 2e-4 * std::abs(ref)) << where;
  }
}

void check_image(const json& ref, const ExrImage& exr) {
  const int n = ref["nchannels"].get<int>();
  EXPECT_EQ(exr.image.width, ref["width"].get<int>());
  EXPECT_EQ(exr.image.height, ref["height"].get<int>());
  EXPECT_EQ(static_cast<int>(exr.channels.size()), n);
  const auto& order = ref["oiio_channel_order"];
  for (int c = 0; c < n; ++c) {
    const std::string name = order[static_cast<std::size_t>(c)].get<std::string>();
    const int slot = slot_of(name, n);
    ASSERT_GE(slot, 0) << "channel " << name;
    const ChannelStats s = stats_of(exr.image, slot);
    SCOPED_TRACE("channel " + name);
    const auto at = [&](const char* key) { return ref[key][static_cast<std::size_t>(c)].get<double>(); };
    EXPECT_EQ(s.nan, ref["stats_nancount"][static_cast<std::size_t>(c)].get<long long>());
    EXPECT_EQ(s.inf, ref["stats_infcount"][static_cast<std::size_t>(c)].get<long long>());
    EXPECT_EQ(s.finite, ref["stats_finitecount"][static_cast<std::size_t>(c)].get<long long>());
    EXPECT_NEAR(s.min, at("stats_min"), printed_tolerance(at("stats_min")));
    EXPECT_NEAR(s.max, at("stats_max"), printed_tolerance(at("stats_max")));
    const double avg = static_cast<double>(s.sum / static_cast<long double>(std::max(s.finite, 1LL)));
    EXPECT_NEAR(avg, at("stats_avg"), average_tolerance(at("stats_avg"), s));
  }
  for (const auto& [xy, values] : ref["probe_pixels_xy"].items()) {
    const int x = std::stoi(xy.substr(0, xy.find(','))), y = std::stoi(xy.substr(xy.find(',') + 1));
    for (int c = 0; c < n; ++c) {
      const int slot = slot_of(order[static_cast<std::size_t>(c)].get<std::string>(), n);
      expect_probe(exr.image.px(x, y)[slot], probe_value(values[static_cast<std::size_t>(c)]),
                   "probe " + xy + " channel " + std::to_string(c));
    }
  }
  if (n != 1) return;
  for (std::size_t i = 0; i < exr.image.pixel_count(); i += 997) {  // replicated to grey, opaque
    const float* p = exr.image.rgba.data() + i * 4;
    if (!std::isnan(p[0])) {
      EXPECT_TRUE(p[1] == p[0] && p[2] == p[0] && p[3] == 1.0f) << "pixel " << i;
    }
  }
}

TEST(ExrFixtures, EveryFixtureMatchesReferenceStats) {
  HDRD_REQUIRE_FIXTURE(stats_path, "fixtures/exr/reference_stats.json");
  const json ref = json::parse(testing::read_file(stats_path));
  ASSERT_GE(ref["images"].size(), 15u);
  for (const auto& image : ref["images"]) {
    const std::string file = image["file"].get<std::string>();
    SCOPED_TRACE(file);
    const auto exr = read_exr(stats_path.parent_path().parent_path() / file);
    ASSERT_TRUE(exr.ok()) << exr.error().message;
    check_image(image, *exr);
  }
}

TEST(ExrFixtures, AttributesOfTheFixtures) {
  HDRD_REQUIRE_FIXTURE(dir, "fixtures/exr");
  const auto tree = read_exr(dir / "Tree.exr");
  ASSERT_TRUE(tree.ok()) << tree.error().message;
  ASSERT_TRUE(tree->chromaticities.has_value());
  EXPECT_NEAR(tree->chromaticities->white.x, 0.3155, 1e-6);  // not D65: adapted by Bradford
  ASSERT_TRUE(tree->white_luminance.has_value());
  EXPECT_NEAR(*tree->white_luminance, 621.0, 1e-3);
  EXPECT_EQ(tree->compression, "piz");
  EXPECT_FALSE(tree->is_xyz);

  const auto carrots = read_exr(dir / "Carrots.exr");
  ASSERT_TRUE(carrots.ok());
  ASSERT_TRUE(carrots->chromaticities.has_value());
  EXPECT_EQ(*carrots->chromaticities, color::kAcesAp0);  // snapped to the exact published set
  EXPECT_EQ(carrots->attributes.count("cameraMake"), 1u);

  const auto cannon = read_exr(dir / "Cannon.exr");
  ASSERT_TRUE(cannon.ok());
  EXPECT_EQ(cannon->compression, "b44");
  EXPECT_FALSE(cannon->chromaticities.has_value());

  const auto wide = read_exr(dir / "WideFloatRange.exr");
  ASSERT_TRUE(wide.ok());
  ASSERT_EQ(wide->channels, std::vector<std::string>{"G"});
  ASSERT_FALSE(wide->warnings.empty());
  EXPECT_NE(wide->warnings[0].find("single channel 'G' replicated to grey"), std::string::npos);

  const auto grey = read_exr(dir / "GrayRampsHorizontal.exr");
  ASSERT_TRUE(grey.ok());
  EXPECT_EQ(grey->channels, std::vector<std::string>{"Y"});
  EXPECT_TRUE(grey->warnings.empty());  // Y is luminance: grey is what it means
}

// XYZ -> Rec.2020 worked out independently of color.cpp (a plain Python solve of the
// BT.2020 primaries and D65 white, SMPTE RP 177); Rec.709 against the published BT.2087
// matrix; Tree (white 0.3155, 0.33165) by the defining property of a Bradford-adapted
// conversion: the source white lands on D65 white.
TEST(ExrFixtures, ToWorkingMatrices) {
  HDRD_REQUIRE_FIXTURE(dir, "fixtures/exr");
  const auto xyz = read_exr(dir / "XYZ.exr");
  ASSERT_TRUE(xyz.ok());
  EXPECT_TRUE(xyz->is_xyz);
  const color::Mat3 m = xyz->to_working();
  const double kXyzTo2020[3][3] = {{1.716651, -0.355671, -0.253366},
                                   {-0.666684, 1.616481, 0.015769},
                                   {0.017640, -0.042771, 0.942103}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m.m[r][c], kXyzTo2020[r][c], 2e-6) << r << "," << c;

  const auto rec709 = read_exr(dir / "Rec709.exr");
  ASSERT_TRUE(rec709.ok());
  const color::Mat3 k = rec709->to_working();  // no attribute: Rec.709, BT.2087 matrix
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(k.m[r][c], color::kBt2087Rec709ToRec2020.m[r][c], 6e-5);

  // Bradford adaptation maps the file's white (1,1,1) to D65 white (1,1,1) in Rec.2020.
  const auto tree = read_exr(dir / "Tree.exr");
  ASSERT_TRUE(tree.ok());
  const color::Vec3 white = tree->to_working() * color::Vec3{1, 1, 1};
  EXPECT_NEAR(white.x, 1.0, 1e-9);
  EXPECT_NEAR(white.y, 1.0, 1e-9);
  EXPECT_NEAR(white.z, 1.0, 1e-9);
}

// published_vectors.md §5: the same picture as Rec.709 RGB and as CIE XYZ (no adaptation)
// agrees to half-float quantisation once both are in the working space.
TEST(ExrFixtures, Rec709AndXyzAgreeInTheWorkingSpace) {
  HDRD_REQUIRE_FIXTURE(dir, "fixtures/exr");
  const auto a = read_exr(dir / "Rec709.exr");
  const auto b = read_exr(dir / "XYZ.exr");
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->image.pixel_count(), b->image.pixel_count());
  const color::Mat3 ma = a->to_working(), mb = b->to_working();
  double worst = 0;
  for (std::size_t i = 0; i < a->image.pixel_count(); ++i) {
    const float* pa = a->image.rgba.data() + i * 4;
    const float* pb = b->image.rgba.data() + i * 4;
    const color::Vec3 wa = ma * color::Vec3{pa[0], pa[1], pa[2]};
    const color::Vec3 wb = mb * color::Vec3{pb[0], pb[1], pb[2]};
    for (int c = 0; c < 3; ++c) {
      // Each half carries a relative error of 2^-11; the matrices amplify it by at most
      // their largest row sum (~2.3), on channels whose magnitude is up to the pixel's max.
      const double scale = std::max({std::abs(wa[0]), std::abs(wa[1]), std::abs(wa[2]), 1e-3});
      worst = std::max(worst, std::abs(wa[c] - wb[c]) / scale);
    }
  }
  EXPECT_LT(worst, 3.0 * 2.3 * std::ldexp(1.0, -11));
  // The centre pixel, as published (colorjs): XYZ [0.40713, 0.36819, 0.21258].
  const float* centre = b->image.px(305, 203);
  EXPECT_NEAR(centre[0], 0.40713, 1e-4);
  EXPECT_NEAR(centre[1], 0.36819, 1e-4);
  EXPECT_NEAR(centre[2], 0.21258, 1e-4);
}

}  // namespace
}  // namespace hdrd::io

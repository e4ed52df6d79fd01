// Tone curves: derived samples from REFERENCE.md §4 and properties looped over every
// registered curve at several peaks (finite, monotonic, black not lifted, never above the
// peak, inverses round-trip, reference white kept where the curve claims it).
#include <gtest/gtest.h>

#include <cmath>

#include "encode/tone/tonemap.hpp"

using namespace hdrd::tonemap;

namespace {

std::unique_ptr<Curve> get(std::string_view name, Display d, const ParamValues& p = {}) {
  auto r = prepare(name, d, p);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

const Display kSdr{100, 0, 100};

TEST(ToneCurves, ReinhardDerivedSamples) {
  auto c = get("reinhard", kSdr);
  EXPECT_NEAR(c->map(0.18), 0.152542, 1e-6);
  EXPECT_NEAR(c->map(1.0), 0.5, 1e-12);
  EXPECT_NEAR(c->map(4.0), 0.8, 1e-12);
}

TEST(ToneCurves, HableDerivedSample) { EXPECT_NEAR(get("hable", kSdr)->map(1.0), 0.304301, 1e-6); }
TEST(ToneCurves, NarkowiczDerivedSample) { EXPECT_NEAR(get("aces-narkowicz", kSdr)->map(1.0), 0.803797, 1e-6); }
TEST(ToneCurves, PbrNeutralDerivedSample) { EXPECT_NEAR(get("pbr-neutral", kSdr)->map(1.0), 0.869091, 1e-6); }

TEST(ToneCurves, Bt2390DerivedSamples) {
  // 1000 cd/m2 source -> 400 cd/m2 target, PQ domain (REFERENCE.md §4).
  const Display d{400, 0, 203};
  auto c = get("bt2390", d, {{"source_peak_nits", 1000}});
  EXPECT_NEAR(c->map(203.0 / 203) * 203, 203.0, 0.05);
  EXPECT_NEAR(c->map(400.0 / 203) * 203, 348.7, 0.05);
  EXPECT_NEAR(c->map(600.0 / 203) * 203, 390.5, 0.05);
}

TEST(ToneCurves, ClipIsExactlyMinOfScaledValueAndPeak) {
  for (double peak : {100.0, 400.0, 1000.0, 4000.0}) {
    const Display d{peak, 0.005, 203};
    auto c = get("clip", d);
    for (double x : {0.0, 0.1, 0.18, 1.0, 2.0, 4.9, 5.0, 19.7, 50.0, 1e6}) {
      EXPECT_DOUBLE_EQ(c->map(x) * d.paper_white_nits, std::min(x * 203, peak)) << x << " @ " << peak;
    }
  }
}

TEST(ToneCurves, LookupAndUnknownNames) {
  EXPECT_NE(find_curve("bt2390"), nullptr);
  EXPECT_EQ(find_curve("nope"), nullptr);
  auto r = prepare("nope", kSdr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("unknown tone curve 'nope'"), std::string::npos);
  EXPECT_NE(r.error().message.find("reinhard"), std::string::npos);  // lists the known ones
}

TEST(ToneCurves, ParameterValidationNamesTheParameter) {
  auto r = prepare("hable", kSdr, {{"white", -1}});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "tone.params.white");
  auto r2 = prepare("hable", kSdr, {{"whiet", 2}});
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.error().message.find("no parameter 'whiet'"), std::string::npos);
  auto r3 = prepare("reinhard", kSdr, {{"white", 2}});
  EXPECT_FALSE(r3.ok());
}

TEST(ToneCurves, RequiredCurvesAreRegistered) {
  for (const char* n : {"clip", "reinhard", "reinhard-extended", "drago", "hable", "hable-piecewise", "day",
                        "lottes", "lottes-hdr", "aces-narkowicz", "aces-narkowicz-hdr", "bt2390", "pbr-neutral",
                        "agx", "ictcp"})
    EXPECT_NE(find_curve(n), nullptr) << n;
}

struct PropertyCase {
  std::string curve;
  double peak;
};
void PrintTo(const PropertyCase& c, std::ostream* os) { *os << c.curve << " at " << c.peak << " cd/m2"; }

class EveryCurve : public ::testing::TestWithParam<PropertyCase> {};

TEST_P(EveryCurve, Properties) {
  const auto& pc = GetParam();
  const Display d{pc.peak, 0.005, pc.peak <= 100 ? pc.peak : 203.0};
  const ToneCurveInfo* info = find_curve(pc.curve);
  ASSERT_NE(info, nullptr);
  auto c = get(pc.curve, d);
  EXPECT_EQ(c->map(0.0), 0.0) << "lifts black";
  double prev = 0;
  for (double lg = -6; lg <= 6; lg += 0.005) {
    const double x = std::pow(10.0, lg);
    const double y = c->map(x);
    ASSERT_TRUE(std::isfinite(y)) << x;
    EXPECT_GE(y, prev - 1e-12) << "not monotonic at x = " << x;
    EXPECT_LE(y, d.max_y() * (1 + 1e-12)) << "above the peak at x = " << x;
    EXPECT_GE(y, 0.0);
    if (info->has_inverse && y > 1e-9 && y < d.max_y() * 0.999) {
      const auto back = c->inverse(y);
      ASSERT_TRUE(back.has_value()) << x;
      EXPECT_NEAR(c->map(*back), y, 1e-7 * std::max(1.0, y)) << "inverse at x = " << x;
    }
    prev = y;
  }
  // Non-finite and negative inputs never produce NaN.
  EXPECT_TRUE(std::isfinite(c->map(-1.0)));
  EXPECT_TRUE(std::isfinite(c->map(1e30)));
  const auto rgb = c->map_rgb({1e30, 0.0, -5.0}, info->default_apply);
  EXPECT_TRUE(std::isfinite(rgb.x) && std::isfinite(rgb.y) && std::isfinite(rgb.z));
  if (info->keeps_reference_white && pc.peak >= 2 * d.paper_white_nits) {
    EXPECT_NEAR(c->map(1.0), 1.0, 1e-9) << "claims to keep reference white";
    const auto white = c->map_rgb({1, 1, 1}, info->default_apply);
    EXPECT_NEAR(white.y, 1.0, 1e-6);
  }
}

std::vector<PropertyCase> all_cases() {
  std::vector<PropertyCase> v;
  for (const auto& c : curves())
    for (double peak : {100.0, 400.0, 600.0, 1000.0, 4000.0, 10000.0}) v.push_back({std::string(c.name), peak});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryCurve, ::testing::ValuesIn(all_cases()),
                         [](const auto& info) {
                           std::string n = info.param.curve + "_" + std::to_string(int(info.param.peak));
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

TEST(ToneCurves, DefaultCurveKeepsReferenceWhite) {
  for (auto mode : {hdrd::Mode::hdr10, hdrd::Mode::hlg, hdrd::Mode::scrgb}) {
    const ToneCurveInfo* info = find_curve(default_curve(mode));
    ASSERT_NE(info, nullptr);
    EXPECT_TRUE(info->keeps_reference_white);
    for (double peak : {406.0, 600.0, 1000.0, 4000.0}) {
      auto c = get(info->name, {peak, 0.005, 203});
      EXPECT_NEAR(c->map(1.0), 1.0, 1e-12) << peak;
    }
  }
}

TEST(ToneCurves, IctcpMapperKeepsHueAtZeroShift) {
  auto c = get("ictcp", {1000, 0, 203});
  const hdrd::color::Vec3 in{8.0, 2.0, 0.5};  // bright orange, compressed
  const auto out = c->map_rgb(in, Apply::rgb);
  const auto a = hdrd::color::rec2020_nits_to_ictcp(in * 203.0);
  const auto b = hdrd::color::rec2020_nits_to_ictcp(out * 203.0);
  EXPECT_NEAR(std::atan2(a.z, a.y), std::atan2(b.z, b.y), 1e-6);
  EXPECT_LT(std::hypot(b.y, b.z), std::hypot(a.y, a.z));  // desaturated toward white
  EXPECT_LT(b.x, a.x);
}

}  // namespace

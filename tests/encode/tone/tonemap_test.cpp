// Tone curves: derived samples from REFERENCE.md §4 and properties looped over every
// registered curve at several peaks (finite, monotonic, black not lifted, never above the
// peak, inverses round-trip, reference white kept where the curve claims it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <ostream>

#include "encode/tone/tonemap.hpp"
#include "tests/testing/standards.hpp"

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

using hdrd::testing::standard::Bt2390Report;  // BT.2390-10 §5.4 written out from the report

TEST(ToneCurves, Bt2390BlackLiftIsTheReportsE3) {
  const Bt2390Report pairs[] = {{0, 1000, 0.05, 600},    {0.005, 4000, 0.1, 1000}, {0, 1000, 0.01, 1000},
                                {0.05, 1000, 0.005, 500}, {0, 4000, 0.02, 400},     {0.1, 2000, 0.1, 2000}};
  for (const auto& r : pairs) {
    const Display d{r.lmax, r.lmin, 203};
    auto c = get("bt2390", d, {{"source_peak_nits", r.lw}, {"source_black_nits", r.lb}, {"black_lift", 1}});
    SCOPED_TRACE(::testing::Message() << r.lb << "/" << r.lw << " -> " << r.lmin << "/" << r.lmax);
    // Black lands on the display black (0.05 cd/m2, not 0.0547), and so does the source black.
    EXPECT_NEAR(c->map(0) * 203, r.lmin, 1e-9 * r.lmin);
    EXPECT_NEAR(c->map(r.lb / 203) * 203, r.lmin, 1e-9 * r.lmin);
    for (double nits : {1e-4, 0.001, 0.01, 0.05, 0.1, 0.5, 1.0, 5.0, 26.0, 100.0, 203.0, 500.0, 1000.0, 3000.0}) {
      // E3 lifts the top a little too (maxLum + b (1 - maxLum)^4): the display peak clips it.
      const double want = std::min(r(nits), r.lmax);
      EXPECT_NEAR(c->map(nits / 203) * 203, want, 1e-9 * want) << nits;
      // Applied as max-rgb, the zero channels of a near-black colour are lifted as the
      // report lifts each of R', G', B'.
      const auto rgb = c->map_rgb({nits / 203, 0, 0}, Apply::max_rgb);
      EXPECT_NEAR(rgb.x * 203, want, 1e-9 * want) << nits;
      EXPECT_NEAR(rgb.y * 203, r.lmin, 1e-9 * r.lmin) << nits;
    }
  }
}

TEST(ToneCurves, Bt2390WithoutTheLiftLiftsNothing) {
  // "No curve lifts black": below the source black the EETF without E3 is the identity, and
  // black is 0.
  const Display d{600, 0.05, 203};
  auto c = get("bt2390", d, {{"source_peak_nits", 1000}, {"source_black_nits", 0.1}});
  EXPECT_EQ(c->map(0), 0.0);
  for (double nits : {1e-4, 0.01, 0.05, 0.099}) EXPECT_NEAR(c->map(nits / 203) * 203, nits, 1e-12) << nits;
  // At the corner (display peak at or above the source peak) it is the identity up to the
  // source peak and the source peak above it.
  auto corner = get("bt2390", {1000, 0, 203}, {{"source_peak_nits", 1000}});
  for (double nits : {1.0, 203.0, 998.0, 999.99}) EXPECT_NEAR(corner->map(nits / 203) * 203, nits, 1e-9 * nits);
  EXPECT_NEAR(corner->map(1500 / 203.0) * 203, 1000, 1e-9);
}

// The numeric kink finder the table checks rely on, on functions whose kinks are known.
TEST(FindKinks, FindsSlopeJumpsAndNotCurvatureJumps) {
  const auto clamp = find_kinks([](double x) { return std::min(x, 3.7); }, 1e-3, 1e3);
  ASSERT_EQ(clamp.size(), 1u);
  EXPECT_NEAR(clamp[0], 3.7, 3.7e-9);
  const auto two = find_kinks([](double x) { return x < 0.02 ? 0.0 : (x < 2 ? x - 0.02 : 1.98 + 0.25 * (x - 2)); },
                              1e-4, 1e4);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_NEAR(two[0], 0.02, 0.02 * 1e-9);
  EXPECT_NEAR(two[1], 2.0, 2e-9);
  // C1 joins (slope continuous, curvature not) are not kinks.
  EXPECT_TRUE(find_kinks([](double x) { return x < 1 ? x : 1 + (x - 1) - 0.2 * (x - 1) * (x - 1); }, 1e-3, 2).empty());
  EXPECT_TRUE(find_kinks([](double x) { return x / (1 + x); }, 1e-4, 1e4).empty());
  // A small jump on a curved function: x^0.5 meeting a steeper power at 10.
  const auto curved = find_kinks([](double x) { return x < 10 ? std::sqrt(x) : std::sqrt(10.0) * std::pow(x / 10, 0.6); },
                                 1e-2, 1e2);
  ASSERT_EQ(curved.size(), 1u);
  EXPECT_NEAR(curved[0], 10.0, 1e-5);
}

// Every curve's declared kinks are kinks the finder sees (or outside its range), and every
// kink it sees is declared: the fast path puts its table nodes on the declared ones.
TEST(ToneCurves, DeclaredKinksAreTheCurvesKinks) {
  for (const auto& info : curves()) {
    if (!info.scalar) continue;
    for (double peak : {100.0, 400.0, 1000.0, 4000.0, 10000.0}) {
      const Display d{peak, 0.005, peak <= 100 ? peak : 203.0};
      auto c = get(info.name, d);
      const auto found = find_kinks([&](double x) { return c->map(x); }, 1e-4, 1e4);
      const auto declared = c->kinks();
      for (double k : found) {
        const bool listed = std::any_of(declared.begin(), declared.end(), [&](double v) { return std::abs(v - k) <= 1e-5 * k; });
        EXPECT_TRUE(listed) << info.name << " at peak " << peak << ": undeclared kink at x = " << k;
      }
    }
  }
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

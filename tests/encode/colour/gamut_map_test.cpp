// The gamut-mapping family (issue 31): over a dense sweep of the source gamut's surface and
// interior, every map keeps every output sample inside the target gamut, and every map but
// clip and highlight keeps the ICtCp hue of what it can still show within 2 degrees, for
// Rec.2020 -> Rec.709, Rec.2020 -> P3-D65, P3-D65 -> Rec.709 and Rec.2020 -> an EDID's
// primaries (a Sony TV whose white is far from D65). The matrices, Bradford and ICtCp are
// computed here again from the primaries and BT.2100, not taken from the library.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "encode/colour/gamut_map.hpp"

using namespace hdrd;

namespace {

using M3 = std::array<std::array<double, 3>, 3>;
using V3 = std::array<double, 3>;

V3 mul(const M3& m, V3 v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}
M3 mul(const M3& a, const M3& b) {
  M3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r[i][j] += a[i][k] * b[k][j];
  return r;
}
M3 inv(const M3& m) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  M3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int a = (j + 1) % 3, b = (j + 2) % 3, c = (i + 1) % 3, d = (i + 2) % 3;
      r[i][j] = (m[a][c] * m[b][d] - m[a][d] * m[b][c]) / det;
    }
  return r;
}

struct Xy {
  double x, y;
};
struct Prim {
  Xy r, g, b, w;
};
V3 xyz_of(Xy c) { return {c.x / c.y, 1.0, (1 - c.x - c.y) / c.y}; }

// SMPTE RP 177: the columns are the primaries' XYZ scaled so that RGB (1, 1, 1) is the white.
M3 npm(const Prim& p) {
  const V3 r = xyz_of(p.r), g = xyz_of(p.g), b = xyz_of(p.b);
  const M3 m{{{r[0], g[0], b[0]}, {r[1], g[1], b[1]}, {r[2], g[2], b[2]}}};
  const V3 s = mul(inv(m), xyz_of(p.w));
  M3 out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out[i][j] = m[i][j] * s[j];
  return out;
}

// Bradford chromatic adaptation from white a to white b.
M3 bradford(Xy a, Xy b) {
  const M3 k{{{0.8951, 0.2664, -0.1614}, {-0.7502, 1.7135, 0.0367}, {0.0389, -0.0685, 1.0296}}};
  const V3 la = mul(k, xyz_of(a)), lb = mul(k, xyz_of(b));
  const M3 d{{{lb[0] / la[0], 0, 0}, {0, lb[1] / la[1], 0}, {0, 0, lb[2] / la[2]}}};
  return mul(inv(k), mul(d, k));
}

const Xy kD65{0.3127, 0.3290};
const Prim k2020{{0.708, 0.292}, {0.170, 0.797}, {0.131, 0.046}, kD65};
const Prim k709{{0.640, 0.330}, {0.300, 0.600}, {0.150, 0.060}, kD65};
const Prim kP3{{0.680, 0.320}, {0.265, 0.690}, {0.150, 0.060}, kD65};
// SNYB905 (Sony TV, ../shared/fixtures/edid): the base block's chromaticity, raw / 1024.
const Prim kSony{{0.625, 0.33984375}, {0.2802734375, 0.5947265625}, {0.1552734375, 0.0703125},
                 {0.283203125, 0.2978515625}};

// RGB with white w -> Rec.2020 (D65), adapted (relative) or not (absolute).
M3 to_2020(const Prim& p, bool adapt) {
  const M3 x = adapt ? mul(bradford(p.w, kD65), npm(p)) : npm(p);
  return mul(inv(npm(k2020)), x);
}

color::Primaries lib(const Prim& p) { return {{p.r.x, p.r.y}, {p.g.x, p.g.y}, {p.b.x, p.b.y}, {p.w.x, p.w.y}}; }
color::Mat3 lib(const M3& m) {
  color::Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = m[i][j];
  return r;
}

// BT.2100 ICtCp of Rec.2020 light in cd/m2.
double pq(double nits) {
  const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
               c3 = 2392.0 / 4096 * 32;
  const double y = std::pow(std::max(nits, 0.0) / 10000, m1);
  return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
}
V3 ictcp(V3 rgb2020) {
  const V3 lms = {(1688 * rgb2020[0] + 2146 * rgb2020[1] + 262 * rgb2020[2]) / 4096,
                  (683 * rgb2020[0] + 2951 * rgb2020[1] + 462 * rgb2020[2]) / 4096,
                  (99 * rgb2020[0] + 309 * rgb2020[1] + 3688 * rgb2020[2]) / 4096};
  const V3 e = {pq(lms[0]), pq(lms[1]), pq(lms[2])};
  return {(2048 * e[0] + 2048 * e[1]) / 4096, (6610 * e[0] - 13613 * e[1] + 7003 * e[2]) / 4096,
          (17933 * e[0] - 17390 * e[1] - 543 * e[2]) / 4096};
}

struct Case {
  std::string name;
  Prim source, target;
  double peak;
};

class GamutFamily : public ::testing::TestWithParam<Case> {};

TEST_P(GamutFamily, EveryMapStaysInsideAndKeepsHue) {
  const Case& c = GetParam();
  const M3 src_to_2020 = to_2020(c.source, true);
  for (std::string_view name : kGamutMappingNames) {
    const auto g = parse_gamut_mapping(name);
    ASSERT_TRUE(g.has_value()) << name;
    SCOPED_TRACE(std::string(name));
    const gamut::Mapper m(*g, lib(src_to_2020), lib(c.target), c.peak);
    const bool absolute = *g == GamutMapping::absolute;
    const M3 back = to_2020(c.target, !absolute);  // the target's RGB -> Rec.2020, as this map reads it
    const bool hue_kept = *g != GamutMapping::clip && *g != GamutMapping::highlight;
    constexpr int kSteps = 16;
    double worst_hue = 0, worst_outside = 0;
    int outside_before = 0, measured = 0;
    for (int r = 0; r <= kSteps; ++r)
      for (int gg = 0; gg <= kSteps; ++gg)
        for (int b = 0; b <= kSteps; ++b) {
          const V3 src = {c.peak * r / kSteps, c.peak * gg / kSteps, c.peak * b / kSteps};
          const V3 w = mul(src_to_2020, src);
          const color::Vec3 out = m.map({w[0], w[1], w[2]});
          for (double v : {out.x, out.y, out.z}) worst_outside = std::max({worst_outside, -v, v - c.peak});
          const V3 direct = mul(inv(back), w);
          if (std::min({direct[0], direct[1], direct[2]}) < -1e-4 * c.peak ||
              std::max({direct[0], direct[1], direct[2]}) > c.peak * (1 + 1e-4))
            ++outside_before;
          if (*g == GamutMapping::highlight) continue;
          const V3 a = ictcp(w), o = ictcp(mul(back, V3{out.x, out.y, out.z}));
          // Hue is defined where there is chroma: what keeps some after mapping.
          if (std::hypot(a[1], a[2]) < 2e-3 || std::hypot(o[1], o[2]) < 2e-3) continue;
          ++measured;
          const double dh = std::remainder(std::atan2(o[2], o[1]) - std::atan2(a[2], a[1]), 2 * M_PI);
          worst_hue = std::max(worst_hue, std::abs(dh) * 180 / M_PI);
        }
    EXPECT_LE(worst_outside, 1e-6 * c.peak) << "a sample outside [0, peak]";
    if (hue_kept) {
      EXPECT_LE(worst_hue, 2.0) << "hue moved (over " << measured << " colours)";
      EXPECT_GT(measured, 1000);
    } else if (*g == GamutMapping::clip) {
      EXPECT_GT(worst_hue, 2.0) << "the sweep tells a per-channel clip from the hue-keeping maps";
    }
    EXPECT_GT(outside_before, 0) << "the sweep should reach outside the target";
  }
}

std::vector<Case> cases() {
  return {{"rec2020_to_rec709_sdr", k2020, k709, 100},  {"rec2020_to_rec709", k2020, k709, 1000},
          {"rec2020_to_p3", k2020, kP3, 1000},          {"p3_to_rec709", kP3, k709, 203},
          {"rec2020_to_edid_sony", k2020, kSony, 600}};
}

INSTANTIATE_TEST_SUITE_P(Pairs, GamutFamily, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

// Colours inside the target stay as they are where a map says so (the fast path relies on
// it), and the maps that compress the source do move colours near the boundary.
TEST(GamutFamily, WhatStaysAndWhatMoves) {
  const M3 src = to_2020(k2020, true), to_709 = inv(to_2020(k709, true));
  const V3 inside = {30, 20, 10}, near_edge = {5, 80, 5};  // Rec.709 light (a muted orange; a vivid green)
  const V3 w_in = mul(inv(to_709), inside), w_edge = mul(inv(to_709), near_edge);
  for (std::string_view name : kGamutMappingNames) {
    const auto g = *parse_gamut_mapping(name);
    const gamut::Mapper m(g, lib(src), lib(k709), 100);
    // A muted colour: kept by all but the maps that scale the whole picture.
    const bool global = g == GamutMapping::saturation || g == GamutMapping::linear || g == GamutMapping::darken;
    const color::Vec3 a = m.map({w_in[0], w_in[1], w_in[2]});
    if (!global) {
      EXPECT_NEAR(a.x, inside[0], 1e-3) << name;
      EXPECT_NEAR(a.y, inside[1], 1e-3) << name;
      EXPECT_NEAR(a.z, inside[2], 1e-3) << name;
    }
    const color::Vec3 e = m.map({w_edge[0], w_edge[1], w_edge[2]});
    const bool moves = global || g == GamutMapping::perceptual;
    EXPECT_EQ(m.keeps_inside(), !moves) << name;
    if (moves) {
      EXPECT_LT(e.y, near_edge[1] - 0.5) << name << ": a colour near the boundary is compressed";
    } else {
      EXPECT_NEAR(e.y, near_edge[1], 1e-3) << name;
    }
  }
  // A source inside the target: nothing to compress.
  const gamut::Mapper narrow(GamutMapping::perceptual, lib(to_2020(k709, true)), lib(kP3), 1000);
  EXPECT_TRUE(narrow.keeps_inside());
}

TEST(GamutFamily, NamesAndTheAlias) {
  EXPECT_EQ(parse_gamut_mapping("desaturate"), GamutMapping::ictcp);  // libplacebo's name for ictcp
  EXPECT_EQ(to_string(GamutMapping::ictcp), "ictcp");
  EXPECT_FALSE(parse_gamut_mapping("nope").has_value());
  for (std::string_view n : kGamutMappingNames) {
    const auto g = parse_gamut_mapping(n);
    ASSERT_TRUE(g.has_value()) << n;
    if (n != "desaturate") {
      EXPECT_EQ(to_string(*g), n);
    }
  }
}

}  // namespace

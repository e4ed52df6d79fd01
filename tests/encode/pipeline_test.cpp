// The frame encoder against the double-precision reference path and against values
// from REFERENCE.md (§1.7 encodings, §2 PQ table, BT.2408 levels) computed independently
// here from the published constants.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "encode/pipeline.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/colour/transfer.hpp"
#include "tests/testing/standards.hpp"

using namespace hdrd;
using color::Vec3;

namespace {

Image solid(int w, int h, Vec3 c) {
  Image img(w, h);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    img.rgba[i * 4] = static_cast<float>(c.x);
    img.rgba[i * 4 + 1] = static_cast<float>(c.y);
    img.rgba[i * 4 + 2] = static_cast<float>(c.z);
    img.rgba[i * 4 + 3] = 1;
  }
  return img;
}

std::array<int, 3> codes_at(const EncodedFrame& f, int x, int y) {
  const std::uint8_t* p = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4;
  if (f.drm_fourcc == kDrmFormatXrgb8888) return {p[2], p[1], p[0]};
  std::uint32_t w;
  std::memcpy(&w, p, 4);
  return {static_cast<int>(w & 1023), static_cast<int>((w >> 10) & 1023), static_cast<int>((w >> 20) & 1023)};
}

EncodedFrame encode(const Image& img, EncodeSettings s) {
  SceneInput in;
  in.image = &img;
  auto r = encode_frame(in, s);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(r).value();
}

EncodeSettings settings(Mode m, std::string curve = "clip") {
  EncodeSettings s;
  s.target = default_target(m);
  s.tone.curve = std::move(curve);
  s.threads = 1;
  return s;
}

TEST(Encode, PaperWhiteLandsOnPq594FullAnd573Narrow) {
  const Image white = solid(4, 2, {1, 1, 1});
  for (const char* curve : {"clip", "pq-shoulder", "bt2390", "ictcp"}) {
    auto f = encode(white, settings(Mode::hdr10, curve));
    EXPECT_EQ(codes_at(f, 0, 0), (std::array<int, 3>{594, 594, 594})) << curve;
    auto s = settings(Mode::hdr10, curve);
    s.target.range = Range::narrow;
    EXPECT_EQ(codes_at(encode(white, s), 1, 1), (std::array<int, 3>{573, 573, 573})) << curve;
  }
}

TEST(Encode, PqTableThroughTheWholeEncoder) {
  // REFERENCE.md §2: absolute luminance -> 10-bit full / narrow codes.
  const std::pair<double, std::array<int, 2>> table[] = {
      {0.005, {15, 77}}, {0.1, {64, 119}},  {1, {153, 195}},   {26, {389, 397}},   {80, {497, 490}},
      {100, {520, 509}}, {203, {594, 573}}, {400, {668, 636}}, {1000, {769, 723}}, {4000, {923, 855}}};
  for (const auto& [nits, codes] : table) {
    Image img = solid(2, 1, {nits, nits, nits});
    auto s = settings(Mode::hdr10);
    s.target.peak_nits = 10000;
    SceneInput in;
    in.image = &img;
    in.units = InputUnits::absolute;
    in.white_luminance_nits = 1.0;  // values are cd/m2
    auto f = encode_frame(in, s);
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(codes_at(*f, 0, 0)[1], codes[0]) << nits;
    s.target.range = Range::narrow;
    EXPECT_EQ(codes_at(*encode_frame(in, s), 1, 0)[1], codes[1]) << nits;
  }
}

TEST(Encode, HlgReferenceWhiteAt75Percent) {
  auto f = encode(solid(2, 2, {1, 1, 1}), settings(Mode::hlg));
  EXPECT_NEAR(codes_at(f, 0, 0)[0], std::lround(0.75 * 1023), 1);  // BT.2408: 203 cd/m2 = 75 % HLG
}

TEST(Encode, ScrgbWhiteIsPaperWhiteOver80AndNegativesKept) {
  auto s = settings(Mode::scrgb);
  s.keep_display_nits = true;
  const Image img = solid(2, 1, {1, 1, 1});
  auto f = encode(img, s);
  const auto* h = reinterpret_cast<const std::uint16_t*>(f.data.data());
  EXPECT_NEAR(detail::half_to_float(h[0]), 203.0 / 80.0, 1e-3);
  EXPECT_EQ(h[3], 0x3C00);
  EXPECT_EQ(f.drm_fourcc, kDrmFormatAbgr16161616f);
  // A pure Rec.2020 green is outside Rec.709: scRGB carries it with negative red/blue.
  SceneInput in;
  Image g = solid(1, 1, {0, 1, 0});
  in.image = &g;
  in.to_working = color::Mat3::identity();  // input already Rec.2020
  auto fg = encode_frame(in, s);
  ASSERT_TRUE(fg.ok());
  const auto* hg = reinterpret_cast<const std::uint16_t*>(fg->data.data());
  EXPECT_LT(detail::half_to_float(hg[0]), 0.0f);
  EXPECT_LT(detail::half_to_float(hg[2]), 0.0f);
}

TEST(Encode, SdrWhiteIs255AndBt1886UsesBlack) {
  auto f = encode(solid(1, 1, {1, 1, 1}), settings(Mode::sdr));
  EXPECT_EQ(codes_at(f, 0, 0), (std::array<int, 3>{255, 255, 255}));
  EXPECT_EQ(f.drm_fourcc, kDrmFormatXrgb8888);
  // sRGB: relative 0.18 -> 0.4614 -> code 118 (REFERENCE.md §2).
  EXPECT_EQ(codes_at(encode(solid(1, 1, {0.18, 0.18, 0.18}), settings(Mode::sdr)), 0, 0)[0], 118);
  // BT.1886 with Lb = 0.1: 0.1 cd/m2 (relative 0.001) is the display's black -> code 0.
  EXPECT_EQ(codes_at(encode(solid(1, 1, {0.001, 0.001, 0.001}), settings(Mode::sdr_bt1886)), 0, 0)[0], 0);
  auto s10 = settings(Mode::sdr);
  s10.target.bits = 10;
  auto f10 = encode(solid(1, 1, {1, 1, 1}), s10);
  EXPECT_EQ(codes_at(f10, 0, 0)[0], 1023);
  EXPECT_EQ(f10.drm_fourcc, kDrmFormatXbgr2101010);
}

TEST(Encode, Rec709PrimariesLandOnTheirRec2020Coordinates) {
  // BT.2087: 709 red = (0.6274, 0.0691, 0.0164) in Rec.2020; with clip at 1000 cd/m2 the
  // codes are PQ of those fractions of 203 cd/m2: no over-saturation of SDR content.
  auto f = encode(solid(1, 1, {1, 0, 0}), settings(Mode::hdr10));
  const auto c = codes_at(f, 0, 0);
  EXPECT_NEAR(c[0], std::lround(transfer::pq_inverse_eotf(0.6274 * 203) * 1023), 1);
  EXPECT_NEAR(c[1], std::lround(transfer::pq_inverse_eotf(0.0691 * 203) * 1023), 1);
  EXPECT_NEAR(c[2], std::lround(transfer::pq_inverse_eotf(0.0164 * 203) * 1023), 1);
}

TEST(Encode, ContentLightLevelsComeFromDecodedCodes) {
  Image img(4, 1);
  const double values[4] = {0.5, 1.0, 2.0, 3.0};
  for (int i = 0; i < 4; ++i) {
    img.rgba[i * 4] = static_cast<float>(values[i]);
    img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = 0.1f;
  }
  auto f = encode(img, settings(Mode::hdr10));
  double mx = 0, sum = 0;
  for (int x = 0; x < 4; ++x) {
    const auto c = codes_at(f, x, 0);
    const double nits = transfer::pq_eotf(std::max({c[0], c[1], c[2]}) / 1023.0);
    mx = std::max(mx, nits);
    sum += nits;
  }
  EXPECT_NEAR(f.content_light.max_cll_nits, mx, 1e-3);
  EXPECT_NEAR(f.content_light.max_fall_nits, sum / 4, 1e-3);
}

TEST(Encode, NanInfAndNegativesFollowTheDocumentedRule) {
  Image img(5, 1);
  const float vals[5] = {NAN, INFINITY, -INFINITY, -1.0f, 1e38f};
  for (int i = 0; i < 5; ++i) img.rgba[i * 4] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = vals[i];
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::sdr, Mode::sdr_bt1886}) {
    auto f = encode(img, settings(m, "pq-shoulder"));
    const int black = codes_at(encode(solid(1, 1, {0, 0, 0}), settings(m, "pq-shoulder")), 0, 0)[0];
    EXPECT_EQ(codes_at(f, 0, 0)[0], black) << "NaN -> black, mode " << to_string(m);
    EXPECT_EQ(codes_at(f, 2, 0)[0], black) << "-Inf -> black";
    EXPECT_EQ(codes_at(f, 3, 0)[0], black) << "negative -> black";
    EXPECT_EQ(codes_at(f, 1, 0), codes_at(f, 4, 0)) << "+Inf behaves as a huge value";
    EXPECT_TRUE(std::isfinite(f.content_light.max_cll_nits));
  }
}

TEST(Encode, ThreadsDoNotChangeTheResult) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 8);
  Image img(97, 53);
  for (auto& v : img.rgba) v = u(rng);
  auto s1 = settings(Mode::hdr10, "pq-shoulder");
  auto s2 = s1;
  s2.threads = 2;
  auto a = encode(img, s1), b = encode(img, s2);
  EXPECT_EQ(a.data, b.data);
  EXPECT_EQ(a.signal16, b.signal16);
  EXPECT_DOUBLE_EQ(a.content_light.max_cll_nits, b.content_light.max_cll_nits);
}

// The fast path (LUTs, float) against the double reference, per mode and curve kind.
struct Case {
  Mode mode;
  const char* curve;
};
void PrintTo(const Case& c, std::ostream* os) { *os << to_string(c.mode) << " " << c.curve; }
class FastVsReference : public ::testing::TestWithParam<Case> {};

TEST_P(FastVsReference, WithinOneCodeAndRarelyOff) {
  const auto [mode, curve] = GetParam();
  std::mt19937 rng(1234);
  std::uniform_real_distribution<double> lg(-5, 3.5);  // 1e-5 .. 3000 x paper white
  Image img(256, 64);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = static_cast<float>(std::pow(10.0, lg(rng)));
    img.rgba[i * 4 + 3] = 1;
  }
  auto s = settings(mode, curve);
  SceneInput in;
  in.image = &img;
  auto prepared = prepare_pipeline(in, s);
  ASSERT_TRUE(prepared.ok());
  auto f = encode_prepared(in, *prepared);
  ASSERT_TRUE(f.ok());
  const auto sig = detail::build_signal_stage(s.target);
  int worst = 0, off = 0, total = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const float* p = img.px(x, y);
      const Vec3 e = reference_signal(s.target, reference_display_nits(*prepared, {p[0], p[1], p[2]}));
      const auto got = codes_at(*f, x, y);
      for (int c = 0; c < 3; ++c) {
        const int want = static_cast<int>(std::clamp(e[c], 0.0, 1.0) * sig.code_scale + 0.5);
        const int d = std::abs(got[c] - want);
        worst = std::max(worst, d);
        off += d != 0;
        ++total;
      }
    }
  EXPECT_LE(worst, 1);
  EXPECT_LT(off, total / 200) << off << " of " << total << " values off by one";
}

INSTANTIATE_TEST_SUITE_P(Modes, FastVsReference,
                         ::testing::Values(Case{Mode::hdr10, "clip"}, Case{Mode::hdr10, "pq-shoulder"},
                                           Case{Mode::hdr10, "hable"}, Case{Mode::hdr10, "reinhard"},
                                           Case{Mode::hdr10, "ictcp"}, Case{Mode::hdr10, "agx"},
                                           Case{Mode::hlg, "pq-shoulder"}, Case{Mode::sdr, "pq-shoulder"},
                                           Case{Mode::sdr, "aces-narkowicz"}, Case{Mode::sdr_bt1886, "pq-shoulder"}),
                         [](const auto& i) {
                           std::string n = std::string(to_string(i.param.mode)) + "_" + i.param.curve;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return n;
                         });

// The gamut-mapping family through the whole encoder (issue 31): Rec.2020 input into each
// mode's container, the fast path (which leaves colours inside to the kernel and sends the
// rest, or with perceptual/saturation/linear/darken everything, to the map) against the
// double reference, within one code.
struct GamutCase {
  Mode mode;
  GamutMapping gamut;
};
void PrintTo(const GamutCase& c, std::ostream* os) { *os << to_string(c.mode) << " " << to_string(c.gamut); }
class GamutFastVsReference : public ::testing::TestWithParam<GamutCase> {};

TEST_P(GamutFastVsReference, WithinOneCode) {
  const auto [mode, gamut] = GetParam();
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> lg(-3, 1.5);
  Image img(96, 32);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = static_cast<float>(std::pow(10.0, lg(rng)) * (rng() % 4 == 0 ? 0 : 1));
    img.rgba[i * 4 + 3] = 1;
  }
  auto s = settings(mode, "pq-shoulder");
  s.gamut = gamut;
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();  // Rec.2020 input: wider than an SDR container
  auto prepared = prepare_pipeline(in, s);
  ASSERT_TRUE(prepared.ok());
  EXPECT_EQ(prepared->gamut_mapper != nullptr, gamut != GamutMapping::ictcp && gamut != GamutMapping::clip);
  auto f = encode_prepared(in, *prepared);
  ASSERT_TRUE(f.ok());
  const auto sig = detail::build_signal_stage(s.target);
  int worst = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const float* p = img.px(x, y);
      const Vec3 e = reference_signal(s.target, reference_display_nits(*prepared, {p[0], p[1], p[2]}));
      const auto got = codes_at(*f, x, y);
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::abs(got[c] - static_cast<int>(std::clamp(e[c], 0.0, 1.0) * sig.code_scale + 0.5)));
    }
  EXPECT_LE(worst, 1);
}

std::vector<GamutCase> gamut_cases() {
  std::vector<GamutCase> v;
  for (Mode m : {Mode::sdr, Mode::hdr10, Mode::hlg})
    for (std::string_view n : kGamutMappingNames)
      if (n != "desaturate") v.push_back({m, *parse_gamut_mapping(n)});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Maps, GamutFastVsReference, ::testing::ValuesIn(gamut_cases()), [](const auto& i) {
  return std::string(to_string(i.param.mode)) + "_" + std::string(to_string(i.param.gamut));
});

// gamut_target display: the map's target is the display's own gamut (an EDID's primaries,
// here SNYB905's with its white at (0.283, 0.298)) inside the Rec.2020 container. Every
// pixel's container light, taken to the display's RGB (its matrix written out from the
// primaries, adapted to D65 as the maps but absolute read it), lies in [0, peak]; with the
// container as the target some do not; the fast path matches the reference.
TEST(Encode, GamutTargetDisplayMapsIntoTheEdidsPrimaries) {
  const color::Primaries sony{{0.625, 0.33984375}, {0.2802734375, 0.5947265625}, {0.1552734375, 0.0703125},
                              {0.283203125, 0.2978515625}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lg(-2, 1.2);
  Image img(64, 16);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = static_cast<float>(std::pow(10.0, lg(rng)) * (rng() % 3 == 0 ? 0 : 1));
    img.rgba[i * 4 + 3] = 1;
  }
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();
  // The display's RGB from Rec.2020 light: XYZ -> display (RP 177), Bradford D65 -> its white.
  auto npm = [](const color::Primaries& p) {
    auto xyz = [](color::Chromaticity c) { return Vec3{c.x / c.y, 1.0, (1 - c.x - c.y) / c.y}; };
    const Vec3 r = xyz(p.red), g = xyz(p.green), b = xyz(p.blue);
    const color::Mat3 m{{{{r.x, g.x, b.x}, {r.y, g.y, b.y}, {r.z, g.z, b.z}}}};
    const Vec3 s = color::inverse(m) * xyz(p.white);
    return color::Mat3{{{{r.x * s.x, g.x * s.y, b.x * s.z}, {r.y * s.x, g.y * s.y, b.y * s.z}, {r.z * s.x, g.z * s.y, b.z * s.z}}}};
  };
  const color::Mat3 k{{{{0.8951, 0.2664, -0.1614}, {-0.7502, 1.7135, 0.0367}, {0.0389, -0.0685, 1.0296}}}};
  auto lms = [&](color::Chromaticity c) { return k * Vec3{c.x / c.y, 1.0, (1 - c.x - c.y) / c.y}; };
  const Vec3 from = lms(color::kD65), to = lms(sony.white);
  const color::Mat3 scale{{{{to.x / from.x, 0, 0}, {0, to.y / from.y, 0}, {0, 0, to.z / from.z}}}};
  const color::Mat3 to_display = color::inverse(npm(sony)) * (color::inverse(k) * scale * k) * npm(color::kRec2020);
  for (GamutMapping g : {GamutMapping::ictcp, GamutMapping::relative, GamutMapping::perceptual}) {
    int outside_container_target = 0;
    for (bool display : {false, true}) {
      auto s = settings(Mode::hdr10, "pq-shoulder");
      s.target.display_primaries = sony;
      s.gamut = g;
      s.gamut_to_display = display;
      auto p = prepare_pipeline(in, s);
      ASSERT_TRUE(p.ok());
      auto f = encode_prepared(in, *p);
      ASSERT_TRUE(f.ok());
      double worst = 0;
      int worst_code = 0;
      for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
          const float* px = img.px(x, y);
          const Vec3 c = reference_display_nits(*p, {px[0], px[1], px[2]});
          const Vec3 d = to_display * c;
          const double out = std::max({-d.x, -d.y, -d.z, d.x - 1000, d.y - 1000, d.z - 1000});
          worst = std::max(worst, out);
          if (!display && out > 1) ++outside_container_target;
          const Vec3 e = reference_signal(s.target, c);
          const auto got = codes_at(*f, x, y);
          for (int ch = 0; ch < 3; ++ch)
            worst_code = std::max(worst_code, std::abs(got[ch] - static_cast<int>(std::clamp(e[ch], 0.0, 1.0) * 1023 + 0.5)));
        }
      EXPECT_LE(worst_code, 1) << to_string(g) << (display ? " display" : " container");
      if (display) {
        EXPECT_LE(worst, 1e-3) << to_string(g) << ": outside the display's gamut";
      }
    }
    EXPECT_GT(outside_container_target, 0) << to_string(g) << ": the container target leaves the display's gamut";
  }
}

TEST(Encode, GamutMapsOfASourceThatFitsChangeNothing) {
  // Rec.709 input into the Rec.709 SDR container: nothing to compress, every map is ictcp.
  Image img(3, 1);
  img.rgba = {0.9f, 0.1f, 0.05f, 1, 0.2f, 0.7f, 0.1f, 1, 0.05f, 0.1f, 0.8f, 1};
  auto s = settings(Mode::sdr, "pq-shoulder");
  const auto want = encode(img, s);
  for (GamutMapping g : {GamutMapping::perceptual, GamutMapping::saturation, GamutMapping::linear, GamutMapping::darken,
                         GamutMapping::relative}) {
    s.gamut = g;
    const auto got = encode(img, s);
    for (int x = 0; x < 3; ++x) EXPECT_EQ(codes_at(got, x, 0), codes_at(want, x, 0)) << to_string(g) << " " << x;
  }
}

// A sequence's per-frame statistics reach the curves that take them: the peak on every
// curve with a source peak, the scene average on those with a knee on it (source_avg_nits).
TEST(Encode, SourcePeakAndAverageReachTheCurve) {
  const Image img = solid(1, 1, {1, 1, 1});
  SceneInput in;
  in.image = &img;
  for (const char* curve : {"st2094-40", "st2094-10", "spline", "bt2390"}) {
    auto s = settings(Mode::sdr, curve);
    auto p = prepare_pipeline(in, s);
    ASSERT_TRUE(p.ok());
    ASSERT_TRUE(set_source_peak(*p, 12.0, 0.4).ok());
    EXPECT_DOUBLE_EQ(p->params.at("source_peak_nits"), 1200) << curve;  // SDR paper white = 100
    const bool has_avg = std::string(curve) != "bt2390";
    EXPECT_EQ(p->params.count("source_avg_nits"), has_avg ? 1u : 0u) << curve;
    if (!has_avg) continue;
    EXPECT_DOUBLE_EQ(p->params.at("source_avg_nits"), 40) << curve;
    auto fresh = tonemap::prepare(curve, {100, s.target.black_nits, 100}, {{"source_peak_nits", 1200}, {"source_avg_nits", 40}});
    ASSERT_TRUE(fresh.ok());
    for (double x : {0.05, 0.4, 2.0, 9.0}) EXPECT_DOUBLE_EQ(p->curve->map(x), (*fresh)->map(x)) << curve << " " << x;
    // Only the average: the peak stays what it was.
    ASSERT_TRUE(set_source_peak(*p, std::nullopt, 0.1).ok());
    EXPECT_DOUBLE_EQ(p->params.at("source_peak_nits"), 1200);
    EXPECT_DOUBLE_EQ(p->params.at("source_avg_nits"), 10);
  }
}

TEST(Encode, UiWhiteLandsAtUiWhiteNits) {
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 2;
  overlay->height = 1;
  overlay->rgba = {1, 1, 1, 1, 1, 1, 1, 0.5f};  // opaque white, half-transparent white
  auto s = settings(Mode::hdr10);
  s.ui.overlay = overlay;
  s.target.ui_white_nits = 400;
  auto f = encode(solid(2, 1, {0, 0, 0}), s);
  EXPECT_EQ(codes_at(f, 0, 0)[0], 668);  // 400 cd/m2 (REFERENCE.md §2)
  // Half alpha over black, blended in linear light: 200 cd/m2.
  EXPECT_EQ(codes_at(f, 1, 0)[0], std::lround(transfer::pq_inverse_eotf(200) * 1023));
}

// ui.inverse_tonemap: linear is the old mapping (the same codes as the default); bt2446c puts
// UI white (V = 1) on the display peak and keeps light below BT.2446-1's knee (58.535 %) linear.
TEST(Encode, UiInverseTonemap) {
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 2;
  overlay->height = 1;
  const float knee_v = static_cast<float>(transfer::srgb_inverse_eotf(0.5));  // light 0.5 < knee
  overlay->rgba = {1, 1, 1, 1, knee_v, knee_v, knee_v, 1};
  auto s = settings(Mode::hdr10);
  s.ui.overlay = overlay;
  s.target.ui_white_nits = 203;
  const auto base = encode(solid(2, 1, {0, 0, 0}), s);
  s.target.sdr_inverse_tonemap = InverseTonemap::linear;
  const auto lin = encode(solid(2, 1, {0, 0, 0}), s);
  for (int x = 0; x < 2; ++x) EXPECT_EQ(codes_at(lin, x, 0), codes_at(base, x, 0));
  EXPECT_EQ(codes_at(lin, 0, 0)[0], 594);  // 203 cd/m2
  s.target.sdr_inverse_tonemap = InverseTonemap::bt2446c;
  const auto itm = encode(solid(2, 1, {0, 0, 0}), s);
  EXPECT_EQ(codes_at(itm, 0, 0)[0], 769);  // the 1000 cd/m2 peak (REFERENCE.md §2)
  EXPECT_EQ(codes_at(itm, 1, 0)[0], codes_at(base, 1, 0)[0]);
}

TEST(Encode, InvalidSettingsAreErrors) {
  const Image img = solid(1, 1, {1, 1, 1});
  auto s = settings(Mode::hdr10, "nope");
  SceneInput in;
  in.image = &img;
  auto r = encode_frame(in, s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "tone.curve");
  s = settings(Mode::hdr10);
  s.target.peak_nits = -5;
  EXPECT_EQ(encode_frame(in, s).error().field, "display.peak_nits");
  s = settings(Mode::hdr10, "agx");
  s.tone.apply = tonemap::Apply::luminance;
  EXPECT_EQ(encode_frame(in, s).error().field, "tone.apply");
}

}  // namespace

namespace {
// The fused SIMD kernel and the staged path (forced by keeping display nits) agree.
TEST(Encode, FusedKernelMatchesStagedPath) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> lg(-4, 3);
  Image img(203, 37);  // not a multiple of any vector width: exercises the tail too
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = static_cast<float>(std::pow(10.0, lg(rng)));
  img.rgba[0] = NAN;
  img.rgba[5] = -INFINITY;
  for (Mode m : {Mode::hdr10, Mode::sdr, Mode::sdr_bt1886, Mode::scrgb})
    for (const char* curve : {"clip", "pq-shoulder", "hable", "reinhard"}) {
      auto fast = settings(m, curve);
      auto staged = fast;
      staged.staged_only = true;
      const auto a = encode(img, fast), b = encode(img, staged);
      ASSERT_EQ(a.data.size(), b.data.size());
      int differ = 0;
      for (std::size_t i = 0; i < a.data.size(); ++i) differ += a.data[i] != b.data[i];
      if (m == Mode::scrgb) {
        // Relative to the pixel's largest channel: small channels come from cancellation in
        // the 2020 -> 709 matrix, where FMA and separate multiply-adds round differently.
        const auto* ha = reinterpret_cast<const std::uint16_t*>(a.data.data());
        const auto* hb = reinterpret_cast<const std::uint16_t*>(b.data.data());
        for (std::size_t p = 0; p < img.pixel_count(); ++p) {
          float mx = 0;
          for (int c = 0; c < 3; ++c) mx = std::max(mx, std::abs(detail::half_to_float(hb[p * 4 + c])));
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(detail::half_to_float(ha[p * 4 + c]), detail::half_to_float(hb[p * 4 + c]), mx * 2e-3 + 1e-6)
                << curve << " pixel " << p;
        }
      } else {
        for (int y = 0; y < img.height; ++y)
          for (int x = 0; x < img.width; ++x) {
            const auto ca = codes_at(a, x, y), cb = codes_at(b, x, y);
            for (int c = 0; c < 3; ++c) ASSERT_LE(std::abs(ca[c] - cb[c]), 1) << to_string(m) << " " << curve;
          }
        EXPECT_LT(differ, static_cast<int>(a.data.size() / 500)) << to_string(m) << " " << curve;
      }
      EXPECT_NEAR(a.content_light.max_cll_nits, b.content_light.max_cll_nits,
                  1e-3 * b.content_light.max_cll_nits + 1e-6);
      EXPECT_NEAR(a.content_light.max_fall_nits, b.content_light.max_fall_nits,
                  1e-3 * b.content_light.max_fall_nits + 1e-6);
    }
}
}  // namespace

namespace {
TEST(Encode, MeasuredContentLightMatchesTheEncoder) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> lg(-3, 2);
  Image img(64, 16);
  for (auto& v : img.rgba) v = static_cast<float>(std::pow(10.0, lg(rng)));
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::scrgb}) {
    const auto f = encode(img, settings(m, "pq-shoulder"));
    const auto c = measure_content_light(f);
    EXPECT_NEAR(c.max_cll_nits, f.content_light.max_cll_nits, 1e-3 * c.max_cll_nits) << to_string(m);
    EXPECT_NEAR(c.max_fall_nits, f.content_light.max_fall_nits, 1e-3 * c.max_fall_nits) << to_string(m);
    EXPECT_GT(c.max_cll_nits, c.max_fall_nits);
    EXPECT_LE(c.max_cll_nits, f.target.peak_nits * 1.001);
  }
}
}  // namespace

namespace {
// UI rows: the fused kernel composites the UI itself (unscaled overlays are copied,
// scaled ones sampled bilinearly); the staged path (kept display nits) is the reference.
// The overlay sits inside the frame, over its left edge and over its right edge.
TEST(Encode, UiRowsMatchTheStagedPath) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0, 4);
  Image img(160, 40);
  for (auto& v : img.rgba) v = u(rng);
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 17;
  overlay->height = 9;
  for (int i = 0; i < 17 * 9; ++i) {
    const float a = (i % 5) / 4.0f;
    overlay->rgba.insert(overlay->rgba.end(), {0.9f, 0.5f, 0.2f, a});
  }
  for (Mode m : {Mode::hdr10, Mode::sdr})
  for (double scale : {1.5, 1.0})
  for (int ui_x : {61, -5, 150}) {
    SCOPED_TRACE(::testing::Message() << "mode " << to_string(m) << ", scale " << scale << ", x " << ui_x);
    auto fast = settings(m, "pq-shoulder");
    fast.ui.overlay = overlay;
    fast.ui.x = ui_x;
    fast.ui.y = 13;
    fast.ui.scale = scale;
    fast.ui.dim = 0.3;
    auto staged = fast;
    staged.staged_only = true;
    const auto a = encode(img, fast), b = encode(img, staged);
    int off = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const auto ca = codes_at(a, x, y), cb = codes_at(b, x, y);
        for (int c = 0; c < 3; ++c) {
          ASSERT_LE(std::abs(ca[c] - cb[c]), 1) << x << "," << y;
          off += ca[c] != cb[c];
        }
      }
    EXPECT_LT(off, img.width * img.height * 3 / 200) << "more than 0.5 % of the values off by one";
    EXPECT_NEAR(a.content_light.max_cll_nits, b.content_light.max_cll_nits, b.content_light.max_cll_nits * 0.01);
    EXPECT_NEAR(a.content_light.max_fall_nits, b.content_light.max_fall_nits, b.content_light.max_fall_nits * 0.002);
    // The overlay is there: a pixel under opaque UI differs from the same frame without UI,
    // and one far from it is the same.
    auto plain = fast;
    plain.ui.overlay.reset();
    const auto p = encode(img, plain);
    const int under = ui_x + 9, away = ui_x > 80 ? 5 : 120;
    EXPECT_NE(codes_at(a, under, 20), codes_at(p, under, 20));
    EXPECT_EQ(codes_at(a, away, 20), codes_at(p, away, 20));
  }
}
}  // namespace

// The fast path's exact quantiser exists for every mode that encodes nits to codes, and
// agrees with the reference signal at the display's black, paper white and peak.
TEST(SignalStage, QuantizerForEveryCodeMode) {
  for (Mode m : {Mode::hdr10, Mode::sdr, Mode::sdr_bt1886})
    for (Range range : {Range::full, Range::narrow})
      for (int bits : {8, 10})
        for (SdrCurve curve : {SdrCurve::srgb, SdrCurve::gamma22}) {
          if (m == Mode::hdr10 && (bits == 8 || curve != SdrCurve::srgb)) continue;
          if (m == Mode::sdr_bt1886 && curve != SdrCurve::srgb) continue;
          DisplayTarget t = default_target(m);
          t.range = range, t.bits = bits, t.sdr_curve = curve;
          const auto sig = detail::build_signal_stage(t);
          ASSERT_FALSE(sig.codes.empty()) << to_string(m) << " " << bits << " bits";
          for (double nits : {t.black_nits, t.paper_white_nits, t.peak_nits, t.peak_nits * 4}) {
            const double e = std::clamp(reference_signal(t, {nits, nits, nits})[0], 0.0, 1.0);
            const int want = static_cast<int>(std::floor(e * sig.code_scale + sig.code_offset + 0.5));
            // Capped at the peak's code (the largest at or below the peak: 722 narrow at 1000
            // cd/m2, whose nearest code 723 decodes above it).
            EXPECT_EQ(sig.codes.code(static_cast<float>(nits)), std::min(want, sig.peak_code))
                << to_string(m) << " " << bits << " bits at " << nits << " nits";
          }
        }
}

// MaxFALL's SIMD sum decodes codes through a quartic per 32 codes: within a thousandth of a
// nit of the exact table everywhere (MaxFALL is reported in whole nits). Narrow range is
// flat below code 64 and above 940, which no quartic follows: it keeps the table.
TEST(SignalStage, CodeLightFitWithinAMilliNit) {
  DisplayTarget t = default_target(Mode::hdr10);
  const auto full = detail::build_signal_stage(t);
  ASSERT_EQ(full.code_nits_poly.size(), 5u * 32);
  EXPECT_LT(full.code_nits_poly_error, 1e-3);
  t.range = Range::narrow;
  const auto narrow = detail::build_signal_stage(t);
  EXPECT_TRUE(narrow.code_nits_poly.empty()) << narrow.code_nits_poly_error;
  EXPECT_GT(narrow.code_nits_poly_error, 1.0);
}

// The luminance samples metering and the temporal decisions read: the same numbers from a
// half image (the SIMD half path) as from the float image of the same values, and each one
// BT.2020's luma of its pixel (Kr 0.2627, Kb 0.0593, in BT.2020 input) times the unit, at
// the documented positions (every step-th pixel). NaN and Inf pixels stay non-finite.
TEST(SceneLuminance, HalfAndFloatInputGiveTheSameSamples) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> light(0.0f, 40.0f);
  const int w = 333, h = 97;  // n / max_samples leaves a partial block and vector
  Image img(w, h);
  ImageHalf half(w, h);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = i % 101 == 0 ? NAN : (i % 103 == 0 ? INFINITY : light(rng) * (i % 5 == 0 ? 1e-4f : 1.0f));
      half.rgba[i * 4 + c] = float_to_half(v);
      img.rgba[i * 4 + c] = half_to_float(half.rgba[i * 4 + c]);  // the same values
    }
    half.rgba[i * 4 + 3] = float_to_half(1.0f), img.rgba[i * 4 + 3] = 1.0f;
  }
  SceneInput from_half, from_float;
  from_half.half = &half, from_float.image = &img;
  from_half.to_working = from_float.to_working = color::to_working(color::Space::rec2020);
  for (const std::size_t max_samples : {std::size_t{1} << 21, std::size_t{4000}, std::size_t{777}}) {
    const auto a = scene_luminance_nits(from_half, 203.0, max_samples);
    const auto b = scene_luminance_nits(from_float, 203.0, max_samples);
    ASSERT_EQ(a.size(), b.size());
    const std::size_t step = std::max<std::size_t>(1, img.pixel_count() / max_samples);
    ASSERT_EQ(a.size(), (img.pixel_count() + step - 1) / step);
    for (std::size_t k = 0; k < a.size(); ++k) {
      const float* p = img.rgba.data() + k * step * 4;
      const double want = (0.2627 * p[0] + 0.6780 * p[1] + 0.0593 * p[2]) * 203.0;
      if (!std::isfinite(want)) {
        EXPECT_FALSE(std::isfinite(a[k])) << k;
        EXPECT_FALSE(std::isfinite(b[k])) << k;
        continue;
      }
      EXPECT_EQ(a[k], b[k]) << "sample " << k << " step " << step;
      EXPECT_NEAR(a[k], want, 1e-5 * want + 1e-9) << "sample " << k << " step " << step;
    }
  }
}

// tone.max_frame_average_nits: the encoded frame's average maxRGB, decoded here from its PQ
// codes with ST 2084's EOTF (tests/testing/standards.hpp), is held at the limit (a display's
// ABL budget) by a lower exposure; `clip` (exact levels) and SDR outputs are left alone.
namespace {

Image bright_yard(int w, int h) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float* p = img.rgba.data() + (static_cast<std::size_t>(y) * w + x) * 4;
      // A sky at 8x diffuse white over a ramp of sunlit ground 0.05-2, a little colour.
      const double v = y < h / 2 ? 8.0 : 0.05 + 1.95 * x / (w - 1);
      p[0] = static_cast<float>(v), p[1] = static_cast<float>(v * 0.9), p[2] = static_cast<float>(v * 1.1), p[3] = 1;
    }
  return img;
}

double decoded_frame_average(const EncodedFrame& f) {
  double sum = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const auto c = codes_at(f, x, y);
      sum += hdrd::testing::standard::pq_eotf(std::max({c[0], c[1], c[2]}) / 1023.0);
    }
  return sum / (static_cast<double>(f.width) * f.height);
}

EncodedFrame encode_limited(const Image& img, EncodeSettings s, std::optional<FrameAverageLimit>* decided = nullptr) {
  SceneInput in;
  in.image = &img;
  auto p = prepare_pipeline(in, s);
  EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().message);
  apply_frame_average_limit(*p, in);
  if (decided) *decided = p->frame_average_limit;
  auto f = encode_prepared(in, *p);
  EXPECT_TRUE(f.ok());
  return std::move(f).value();
}

}  // namespace

TEST(Encode, FrameAverageLimitHoldsTheDecodedAverage) {
  for (auto [w, h] : {std::pair{64, 36}, std::pair{256, 144}}) {  // every pixel sampled; every other one
    const Image img = bright_yard(w, h);
    EncodeSettings s = settings(Mode::hdr10, "");  // the mode's default curve
    const double free_average = decoded_frame_average(encode(img, s));
    ASSERT_GT(free_average, 500) << "the test frame must be above the limit without it";
    s.tone.max_frame_average_nits = 400;
    std::optional<FrameAverageLimit> d;
    const double limited = decoded_frame_average(encode_limited(img, s, &d));
    ASSERT_TRUE(d && d->applied);
    EXPECT_LE(limited, 400 * 1.01) << w;
    EXPECT_GE(limited, 400 * 0.97) << w << ": lowered only as far as needed";
    EXPECT_LT(d->exposure_factor, 1);
    EXPECT_NEAR(d->predicted_nits, free_average, 0.01 * free_average);
    // Below the limit: nothing changes.
    s.tone.max_frame_average_nits = 2 * free_average;
    const EncodedFrame same = encode_limited(img, s, &d);
    EXPECT_FALSE(d->applied);
    EXPECT_EQ(same.data, encode(img, settings(Mode::hdr10, "")).data);
  }
}

TEST(Encode, FrameAverageLimitLeavesClipAndSdrExact) {
  const Image img = bright_yard(64, 36);
  for (auto [mode, curve] : {std::pair{Mode::hdr10, "clip"}, std::pair{Mode::sdr, ""}}) {
    EncodeSettings s = settings(mode, curve);
    const EncodedFrame free = encode(img, s);
    s.tone.max_frame_average_nits = 100;
    std::optional<FrameAverageLimit> d;
    const EncodedFrame limited = encode_limited(img, s, &d);
    ASSERT_TRUE(d);
    EXPECT_FALSE(d->applied) << curve;
    EXPECT_FALSE(d->not_applied.empty());
    EXPECT_EQ(limited.data, free.data) << "levels stay exact";
  }
}

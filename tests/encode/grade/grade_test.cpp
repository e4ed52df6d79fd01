// load_grade and the three placements: clear one-line errors, identity grades, the baked
// tone curve against the analytic pipeline (and the peak it records), and the property
// that makes display placement worth having: one look, the same hues on SDR and HDR10.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/tonemap.hpp"
#include "encode/colour/transfer.hpp"
#include "tests/encode/grade/grade_testing.hpp"
#include "tests/testing/testing.hpp"

using namespace hdrd;
using namespace hdrd::lut;
using grade::GradeSettings;
using grade::Placement;
using grade::Shaper;

namespace {

std::shared_ptr<const grade::Grade> load_ok(const GradeSettings& s, double peak = 1000,
                                            std::vector<std::string>* warnings = nullptr) {
  auto g = grade::load_grade(s, peak, warnings);
  EXPECT_TRUE(g.ok()) << g.error().message;
  return g.ok() ? *g : nullptr;
}

std::string write_identity(const hdrd::testing::TempDir& dir, int size, const std::string& name,
                           std::vector<std::string> comments = {}) {
  CubeFile c;
  c.lut3d = Lut3D::identity(size);
  c.comments = std::move(comments);
  const auto path = (dir / name).string();
  EXPECT_TRUE(write_cube(c, path).ok());
  return path;
}

TEST(Grade, NamesRoundTrip) {
  for (auto p : {Placement::scene, Placement::display, Placement::baked})
    EXPECT_EQ(grade::parse_placement(grade::to_string(p)), p);
  for (auto s : {Shaper::pq, Shaper::log2, Shaper::sqrt, Shaper::sqrt_sqrt, Shaper::none})
    EXPECT_EQ(grade::parse_shaper(grade::to_string(s)), s);
  EXPECT_FALSE(grade::parse_placement("before"));
  EXPECT_EQ(grade::to_string(Shaper::sqrt_sqrt), "sqrt-sqrt");
}

TEST(Grade, ClearOneLineErrors) {
  hdrd::testing::TempDir dir;
  const auto bad = (dir / "bad.cube").string();
  {
    std::ofstream f(bad);
    f << "TITLE \"x\"\nLUT_3D_SIZE 2\n0 0 0\n0 0\n";
  }
  struct Case {
    GradeSettings s;
    const char* code;
    std::vector<std::string> says;
  };
  GradeSettings missing;
  missing.lut_path = (dir / "nope.cube").string();
  GradeSettings malformed;
  malformed.lut_path = bad;
  GradeSettings missing_other;
  missing_other.lut_path = (dir / "nope.spi3d").string();
  GradeSettings not_a_lut;
  not_a_lut.lut_path = (dir / "text.spi3d").string();
  { std::ofstream(not_a_lut.lut_path) << "hello\n"; }
  GradeSettings no_config;
  no_config.ocio_look = "warm";
  no_config.ocio_config = (dir / "none.ocio").string();
  const std::vector<Case> cases = {
      {GradeSettings{}, "grade.empty", {"no grade"}},
      {missing, "grade.file", {"nope.cube", "no such LUT file"}},
      {malformed, "cube.syntax", {"bad.cube:4:", "expected 3 numbers"}},
      {missing_other, "grade.file", {"nope.spi3d"}},
      {not_a_lut, "grade.format", {"text.spi3d", "OpenColorIO cannot read it"}},
      {no_config, "grade.ocio", {"none.ocio", "no such file"}},
  };
  for (const auto& c : cases) {
    auto g = grade::load_grade(c.s, 1000, nullptr);
    ASSERT_FALSE(g.ok()) << c.code;
    EXPECT_EQ(g.error().code, c.code) << g.error().message;
    for (const auto& s : c.says) EXPECT_NE(g.error().message.find(s), std::string::npos) << g.error().message;
    EXPECT_EQ(g.error().message.find('\n'), std::string::npos) << g.error().message;
  }
}

// An identity LUT is the identity: in its own signal units (what the table sees) within
// 1e-5, for every placement and shaper.
TEST(Grade, IdentityLutIsIdentity) {
  hdrd::testing::TempDir dir;
  const auto path = write_identity(dir, 33, "id.cube");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto placement : {Placement::scene, Placement::display, Placement::baked})
    for (auto shaper : {Shaper::pq, Shaper::log2, Shaper::sqrt, Shaper::sqrt_sqrt}) {
      if (placement == Placement::display && shaper != Shaper::pq) continue;
      GradeSettings s;
      s.lut_path = path;
      s.placement = placement;
      if (placement != Placement::display) s.shaper = shaper;
      auto g = load_ok(s);
      ASSERT_TRUE(g);
      const ShaperSpec in = placement == Placement::display ? ShaperSpec{Shaper::pq, 0, 10000}
                                                            : ShaperSpec::defaults(shaper);
      const ShaperSpec out = placement == Placement::scene ? in : ShaperSpec{Shaper::pq, 0, 10000};
      double worst = 0;
      for (int i = 0; i < 3000; ++i) {
        float px[4];
        double want[3];
        for (int c = 0; c < 3; ++c) {
          const double sv = u(rng);
          px[c] = float(unshape(in, sv));
          want[c] = shape(in, px[c]);  // the signal of the value actually passed
        }
        px[3] = 0.5f;
        g->apply(px, 1);
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(shape(out, px[c]) - want[c]));
        ASSERT_EQ(px[3], 0.5f);
      }
      EXPECT_LE(worst, 1e-5) << grade::to_string(placement) << " " << grade::to_string(shaper);
    }
}

TEST(Grade, DescribeAndGpuLut) {
  hdrd::testing::TempDir dir;
  const auto path = write_identity(dir, 17, "id17.cube");
  GradeSettings s;
  s.lut_path = path;
  s.placement = Placement::scene;
  s.shaper = Shaper::log2;
  s.trilinear = true;
  auto g = load_ok(s);
  ASSERT_TRUE(g);
  const auto j = g->describe();
  EXPECT_EQ(j["placement"], "scene");
  EXPECT_EQ(j["shaper"], "log2");
  EXPECT_EQ(j["size"], 17);
  EXPECT_EQ(j["interpolation"], "trilinear");
  EXPECT_EQ(j["file"], path);
  const auto gpu = g->gpu_lut();
  ASSERT_TRUE(gpu);
  EXPECT_EQ(gpu->size, 17);
  EXPECT_EQ(gpu->shaper, Shaper::log2);
  EXPECT_EQ(gpu->shaper_min, -12);
  EXPECT_EQ(gpu->shaper_max, 9);
  EXPECT_TRUE(gpu->trilinear);
  EXPECT_EQ(gpu->rgb, Lut3D::identity(17).rgb);
}

// An explicit range ("--lut-shaper log2:-6:10") wins over the file's and the default.
TEST(Grade, ExplicitShaperRange) {
  hdrd::testing::TempDir dir;
  GradeSettings s;
  s.lut_path = write_identity(dir, 5, "log.cube", {shaper_comment({Shaper::log2, -8, 8})});
  s.placement = Placement::scene;
  s.shaper = Shaper::log2;
  s.shaper_range = std::pair{-6.0, 10.0};
  auto g = load_ok(s);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->describe()["shaper"], "log2:-6:10");
  EXPECT_EQ(g->gpu_lut()->shaper_min, -6);
  EXPECT_EQ(g->gpu_lut()->shaper_max, 10);
  s.shaper = Shaper::sqrt;
  s.shaper_range = std::pair{0.0, 16.0};
  EXPECT_EQ(load_ok(s)->describe()["shaper"], "sqrt:16");
}

TEST(Grade, ShaperChoiceAndWarnings) {
  hdrd::testing::TempDir dir;
  const auto path = write_identity(dir, 5, "log.cube", {shaper_comment({Shaper::log2, -8, 8})});
  GradeSettings s;
  s.lut_path = path;
  s.placement = Placement::scene;
  std::vector<std::string> w;
  auto g = load_ok(s, 1000, &w);
  EXPECT_TRUE(w.empty());
  EXPECT_EQ(g->describe()["shaper"], "log2:-8:8");  // the file's recorded shaper
  s.shaper = Shaper::pq;
  g = load_ok(s, 1000, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("records shaper log2:-8:8, using pq"), std::string::npos) << w[0];
  w.clear();
  s.placement = Placement::display;
  g = load_ok(s, 1000, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("ignored for display placement"), std::string::npos) << w[0];
}

// Baking the tone curve into the LUT: the measured bake error against the analytic
// pipeline is small, the peak is recorded, and a different display peak is a warning.
TEST(Grade, BakedToneCurve) {
  hdrd::testing::TempDir dir;
  BakeRequest rq;
  rq.curve = std::string(tonemap::default_curve(Mode::hdr10));
  rq.display = {1000, 0, 203};
  rq.size = 33;
  rq.error_samples = 4000;
  auto baked = bake_tone_curve(rq);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  RecordProperty("bake33_max_pq", fmt::format("{:.3g}", baked->error.max_pq));
  RecordProperty("bake33_mean_pq", fmt::format("{:.3g}", baked->error.mean_pq));
  EXPECT_LT(baked->error.max_code10, 4.0);   // a 33^3 PQ-shaped bake: a few 10-bit codes at worst
  EXPECT_LT(baked->error.mean_pq, 1.0 / 1023);
  const auto path = (dir / "baked.cube").string();
  ASSERT_TRUE(write_cube(baked->cube, path).ok());

  GradeSettings s;
  s.lut_path = path;
  s.placement = Placement::baked;
  std::vector<std::string> w;
  auto g = load_ok(s, 1000, &w);
  EXPECT_TRUE(w.empty()) << w.front();
  ASSERT_TRUE(g);
  EXPECT_EQ(g->baked_peak_nits(), 1000.0);
  EXPECT_EQ(g->describe()["baked_peak_nits"], 1000.0);
  // Independent check of the loaded grade: mid grey and white against the curve itself.
  auto curve = tonemap::prepare(rq.curve, rq.display);
  ASSERT_TRUE(curve.ok());
  for (double x : {0.18, 1.0, 4.0}) {
    float px[4] = {float(x), float(x), float(x), 1};
    g->apply(px, 1);
    const double want = (*curve)->map(x) * 203;
    EXPECT_NEAR(transfer::pq_inverse_eotf(px[1]), transfer::pq_inverse_eotf(want), 1.5 / 1023) << x;
  }
  g = load_ok(s, 600, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("baked for a 1000 cd/m2 peak, but the display peak is 600"), std::string::npos) << w[0];
  w.clear();
  s.placement = Placement::display;
  g = load_ok(s, 1000, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("use --grade baked"), std::string::npos) << w[0];
  w.clear();
  s.placement = Placement::baked;
  s.lut_path = write_identity(dir, 5, "plain.cube");
  g = load_ok(s, 1000, &w);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("does not record the peak"), std::string::npos) << w[0];
}

TEST(Grade, BakeErrorShrinksWithSize) {
  BakeRequest rq;
  rq.curve = std::string(tonemap::default_curve(Mode::hdr10));
  rq.display = {1000, 0, 203};
  rq.error_samples = 2000;
  double previous = 1;
  for (int size : {9, 17, 33}) {
    rq.size = size;
    auto b = bake_tone_curve(rq);
    ASSERT_TRUE(b.ok());
    EXPECT_LT(b->error.max_pq, previous) << size;
    previous = b->error.max_pq;
  }
}

// ---- SDR and HDR10 from one display-referred look: the same hues ----------------------

// The look, evaluated in PQ display space: a 20 degree hue rotation and 10 % more chroma in
// ICtCp, independent of intensity, as a 33^3 display-placement LUT.
CubeFile hue_rotation_look() {
  CubeFile c;
  c.lut3d = Lut3D::identity(33);
  const double a = 20.0 * std::numbers::pi / 180, k = 1.1;
  for (std::size_t e = 0; e < c.lut3d->rgb.size(); e += 3) {
    const color::Vec3 nits{transfer::pq_eotf(c.lut3d->rgb[e]), transfer::pq_eotf(c.lut3d->rgb[e + 1]),
                           transfer::pq_eotf(c.lut3d->rgb[e + 2])};
    const auto i = color::rec2020_nits_to_ictcp(nits);
    const color::Vec3 r{i.x, k * (i.y * std::cos(a) - i.z * std::sin(a)), k * (i.y * std::sin(a) + i.z * std::cos(a))};
    const auto out = color::ictcp_to_rec2020_nits(r);
    c.lut3d->rgb[e] = float(transfer::pq_inverse_eotf(std::max(out.x, 0.0)));
    c.lut3d->rgb[e + 1] = float(transfer::pq_inverse_eotf(std::max(out.y, 0.0)));
    c.lut3d->rgb[e + 2] = float(transfer::pq_inverse_eotf(std::max(out.z, 0.0)));
  }
  return c;
}

// Scene colours: 12 hues x 2 saturations x 5 levels, inside Rec.709 (so SDR needs no
// gamut mapping before the look), as relative Rec.2020.
Image hue_test_image() {
  Image img(12 * 2, 5);
  const color::Mat3 to2020 = color::rgb_to_rgb(color::kRec709, color::kRec2020);
  const double levels[] = {0.05, 0.18, 0.5, 1.0, 2.0};
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 24; ++x) {
      const double h = (x / 2) * 30.0 * std::numbers::pi / 180, sat = x % 2 ? 0.6 : 0.3;
      const color::Vec3 c709{1 + sat * std::cos(h), 1 + sat * std::cos(h - 2.0944), 1 + sat * std::cos(h + 2.0944)};
      const color::Vec3 w = to2020 * (c709 * (levels[y] / color::dot(color::kRec709Luma, c709)));
      float* p = img.px(x, y);
      p[0] = float(w.x), p[1] = float(w.y), p[2] = float(w.z), p[3] = 1;
    }
  return img;
}

std::vector<color::Vec3> displayed_ictcp(const Image& img, Mode mode, std::shared_ptr<const grade::Grade> g,
                                         const std::string& curve) {
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();
  EncodeSettings s;
  s.target = default_target(mode);
  s.tone.curve = curve;
  s.grade = std::move(g);
  s.keep_display_nits = true;
  s.threads = 1;
  auto f = encode_frame(in, s);
  EXPECT_TRUE(f.ok()) << f.error().message;
  std::vector<color::Vec3> out;
  if (!f.ok()) return out;
  const color::Mat3 to2020 = color::rgb_to_rgb(s.target.container(), color::kRec2020);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const float* p = f->display_nits->rgba.data() + 4 * i;
    out.push_back(color::rec2020_nits_to_ictcp(to2020 * color::Vec3{p[0], p[1], p[2]}));
  }
  return out;
}

double hue_deg(color::Vec3 ictcp) { return std::atan2(ictcp.z, ictcp.y) * 180 / std::numbers::pi; }
double chroma(color::Vec3 ictcp) { return std::hypot(ictcp.y, ictcp.z); }
double hue_diff_deg(double a, double b) { return std::fabs(std::remainder(a - b, 360.0)); }

TEST(Grade, DisplayLookKeepsHueAcrossSdrAndHdr10) {
  hdrd::testing::TempDir dir;
  const auto path = (dir / "look.cube").string();
  ASSERT_TRUE(write_cube(hue_rotation_look(), path).ok());
  GradeSettings s;
  s.lut_path = path;
  s.placement = Placement::display;
  const auto img = hue_test_image();
  // The hue-preserving ICtCp mapper isolates the grade; the default curve is checked too.
  for (const std::string& curve : {std::string("ictcp"), std::string(tonemap::default_curve(Mode::hdr10))}) {
    auto sdr_g = load_ok(s, default_target(Mode::sdr).peak_nits);
    auto hdr_g = load_ok(s, default_target(Mode::hdr10).peak_nits);
    const auto sdr = displayed_ictcp(img, Mode::sdr, sdr_g, curve);
    const auto hdr = displayed_ictcp(img, Mode::hdr10, hdr_g, curve);
    const auto sdr_plain = displayed_ictcp(img, Mode::sdr, nullptr, curve);
    ASSERT_EQ(sdr.size(), img.pixel_count());
    ASSERT_EQ(hdr.size(), img.pixel_count());
    int compared = 0;
    double worst = 0, rotation = 0;
    for (std::size_t i = 0; i < sdr.size(); ++i) {
      if (std::min(chroma(sdr[i]), chroma(hdr[i])) < 0.02) continue;
      worst = std::max(worst, hue_diff_deg(hue_deg(sdr[i]), hue_deg(hdr[i])));
      rotation += std::remainder(hue_deg(sdr[i]) - hue_deg(sdr_plain[i]), 360.0);
      ++compared;
    }
    EXPECT_GE(compared, 40) << curve;
    EXPECT_LE(worst, 2.0) << curve;
    EXPECT_NEAR(rotation / compared, 20.0, 2.0) << curve << ": the look did act";
    RecordProperty("hue_worst_deg_" + curve, fmt::format("{:.3g}", worst));
  }
}

}  // namespace

// The suite's checks fail on broken frames: codes off by N, codes above the peak,
// wrong content light, corrupted metadata bytes and PNG chunks. Each broken input is
// made from a good frame, which the same check passes first.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>

#include <fmt/format.h>

#include "display/hdr_metadata.hpp"
#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "patterns/patterns.hpp"
#include "patterns/selftest.hpp"

namespace hdrd::patterns {
namespace {

EncodedFrame encode_uniform(const DisplayTarget& t, double relative, const std::string& curve = "clip") {
  Image img(8, 8);
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    img.rgba[i * 4] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = float(relative), img.rgba[i * 4 + 3] = 1;
  EncodeSettings s;
  s.target = t;
  s.tone.curve = curve;
  SceneInput in;
  in.image = &img;
  return encode_frame(in, s).value();
}

// An encoder whose signal stage is off by `n` codes: every 10-bit code shifted.
void shift_codes(EncodedFrame& f, int n) {
  for (std::size_t i = 0; i + 4 <= f.data.size(); i += 4) {
    std::uint32_t w;
    std::memcpy(&w, f.data.data() + i, 4);
    std::uint32_t out = 0;
    for (int c = 0; c < 3; ++c) {
      const int code = std::clamp(int((w >> (10 * c)) & 1023) + n, 0, 1023);
      out |= std::uint32_t(code) << (10 * c);
    }
    std::memcpy(f.data.data() + i, &out, 4);
  }
}

TEST(BrokenEncoder, PaperWhiteOffByTwoCodesFails) {
  EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 1.0);
  ASSERT_TRUE(check_paper_white(f, "clip").passed) << check_paper_white(f, "clip").detail;
  shift_codes(f, 2);
  const Check c = check_paper_white(f, "clip");
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find("596"), std::string::npos) << c.detail;
  EXPECT_NE(c.source.find("594"), std::string::npos) << c.source;
}

TEST(BrokenEncoder, HlgPaperWhiteOffFails) {
  EncodedFrame f = encode_uniform(default_target(Mode::hlg), 1.0);
  ASSERT_TRUE(check_paper_white(f, "clip").passed) << check_paper_white(f, "clip").detail;
  // BT.2408: 203 cd/m2 on a 1000 cd/m2 HLG display is 75 %, 10-bit full range code 767.
  shift_codes(f, -3);
  const Check c = check_paper_white(f, "clip");
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find("(764, 764, 764) vs 767"), std::string::npos) << c.detail;
}

TEST(BrokenEncoder, ScrgbWhiteNotOver80Fails) {
  DisplayTarget t = default_target(Mode::scrgb);
  EncodedFrame f = encode_uniform(t, 1.0);
  ASSERT_TRUE(check_paper_white(f, "clip").passed);
  // An encoder that forgot the 80 cd/m2 unit and wrote paper white as 1.0.
  const std::uint16_t one = 0x3C00;
  for (std::size_t i = 0; i + 8 <= f.data.size(); i += 8)
    for (int c = 0; c < 3; ++c) std::memcpy(f.data.data() + i + 2 * c, &one, 2);
  EXPECT_FALSE(check_paper_white(f, "clip").passed);
}

TEST(BrokenEncoder, CodesAboveThePeakFail) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.peak_nits = 600;
  EncodedFrame f = encode_uniform(t, 100.0);  // far above the peak: clipped to 600 cd/m2
  ASSERT_TRUE(check_peak(f, "t").passed) << check_peak(f, "t").detail;
  shift_codes(f, 1);
  const Check c = check_peak(f, "t");
  EXPECT_FALSE(c.passed);
  // The largest 10-bit full-range PQ code at or below 600 cd/m2 is 712 (598.33 cd/m2); the
  // broken encoder wrote 713, which decodes to 603.75 cd/m2, above the peak.
  EXPECT_NE(c.detail.find("603.7544 cd/m2 (code 713) vs peak 600 cd/m2"), std::string::npos) << c.detail;
}

TEST(BrokenEncoder, WrongContentLightFails) {
  EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 2.0);
  ASSERT_TRUE(check_content_light(f, "t").passed) << check_content_light(f, "t").detail;
  f.content_light.max_cll_nits *= 1.05;
  const Check c = check_content_light(f, "t");
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find(fmt::format("frame says {:.2f}", f.content_light.max_cll_nits)), std::string::npos) << c.detail;
}

TEST(BrokenEncoder, CorruptedMetadataBytesFail) {
  EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 2.0);
  auto m = display::make_hdr_output_metadata(Mode::hdr10, f.mastering, f.content_light);
  ASSERT_TRUE(m);
  auto bytes = display::serialize(*m);
  ASSERT_TRUE(check_metadata_blob(f, bytes).passed) << check_metadata_blob(f, bytes).detail;
  auto eotf = bytes;
  eotf[4] = 3;  // HLG in an HDR10 stream
  EXPECT_FALSE(check_metadata_blob(f, eotf).passed);
  auto cll = bytes;
  cll[26] ^= 0x10;  // MaxCLL off by 16 cd/m2
  EXPECT_FALSE(check_metadata_blob(f, cll).passed);
  auto big_endian = bytes;
  std::swap(big_endian[22], big_endian[23]);  // max luminance written big-endian
  EXPECT_FALSE(check_metadata_blob(f, big_endian).passed);
}

TEST(BrokenEncoder, WrongPngChunksFail) {
  EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 2.0);
  auto png = io::read_png_info_memory(io::encode_png(f).value());
  ASSERT_TRUE(png);
  ASSERT_TRUE(check_png(f, *png).passed) << check_png(f, *png).detail;
  auto wrong = *png;
  (*wrong.cicp)[1] = 18;  // HLG transfer in a PQ file
  EXPECT_FALSE(check_png(f, wrong).passed);
  auto no_clli = *png;
  no_clli.clli.reset();
  EXPECT_FALSE(check_png(f, no_clli).passed);
}

TEST(BrokenEncoder, OversaturatedSdrInHdrFails) {
  // Rec.709 red, green, blue written as if their values were Rec.2020 (no primaries
  // conversion): the classic over-saturation bug.
  DisplayTarget t = default_target(Mode::hdr10);
  Image img(48, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 48; ++x) img.px(x, y)[x / 16] = 0.5f, img.px(x, y)[3] = 1;
  EncodeSettings s;
  s.target = t;
  s.tone.curve = "clip";
  SceneInput in;
  in.image = &img;
  auto good = encode_frame(in, s);
  ASSERT_TRUE(good);
  EXPECT_TRUE(check_rec709_primaries(*good, "clip").passed) << check_rec709_primaries(*good, "clip").detail;
  in.to_working = color::Mat3::identity();
  auto bad = encode_frame(in, s);
  ASSERT_TRUE(bad);
  EXPECT_FALSE(check_rec709_primaries(*bad, "clip").passed);
}

TEST(BrokenEncoder, WindowOffByTwoCodesFails) {
  PatternOptions o;
  o.width = 64, o.height = 36, o.level_nits = 400;
  auto f = make_pattern("window", default_target(Mode::hdr10), o, false);
  ASSERT_TRUE(f);
  ASSERT_TRUE(check_window(*f, 400).passed);
  shift_codes(*f, 2);
  const Check c = check_window(*f, 400);
  EXPECT_FALSE(c.passed);
  // REFERENCE.md §2: 400 cd/m2 is PQ code 668 (10-bit full range).
  EXPECT_NE(c.detail.find("codes (670, 670, 670) vs 668"), std::string::npos) << c.detail;
}

// Issue 15's checks fail on the breakages they exist for.
TEST(BrokenEncoder, DumpThatIsNotTheDisplayedLightFails) {
  // A Rec.2020 blue of 800 cd/m2 on a 1000 cd/m2 HLG display: the old encoder sent
  // (0, 0, 1023) and dumped 800, which BT.2100's EOTF shows at 569.
  Image img(4, 2);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) img.rgba[i * 4 + 2] = 800, img.rgba[i * 4 + 3] = 1;
  EncodeSettings s;
  s.target = default_target(Mode::hlg);
  s.tone.curve = "clip";
  s.keep_display_nits = true;
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();
  in.units = InputUnits::absolute;
  auto f = encode_frame(in, s);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(check_display_volume(*f, "blue").passed) << check_display_volume(*f, "blue").detail;
  for (std::size_t i = 0; i + 4 <= f->data.size(); i += 4) {
    const std::uint32_t blue = 1023u << 20;  // the old clip: (0, 0, 1023)
    std::memcpy(f->data.data() + i, &blue, 4);
  }
  for (std::size_t i = 0; i < img.pixel_count(); ++i) f->display_nits->rgba[i * 4 + 2] = 800;
  const Check c = check_display_volume(*f, "blue");
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find("800.00"), std::string::npos) << c.detail;
  EXPECT_NE(c.detail.find("568."), std::string::npos) << c.detail;  // what the codes show
}

TEST(BrokenEncoder, ToneTableOffAtAKinkFails) {
  const DisplayTarget t = default_target(Mode::hdr10);
  auto curve = tonemap::prepare("bt2390", {t.peak_nits, t.black_nits, t.paper_white_nits});
  ASSERT_TRUE(curve.ok());
  const std::vector<double> xs = {1000 / 203.0 * 0.999, 1000 / 203.0, 1000 / 203.0 * 1.001};
  Image img(3, 1);
  for (int i = 0; i < 3; ++i) img.rgba[i * 4] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = float(xs[i]), img.rgba[i * 4 + 3] = 1;
  EncodeSettings s;
  s.target = t;
  s.tone.curve = "bt2390";
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();
  auto f = encode_frame(in, s);
  ASSERT_TRUE(f.ok());
  const double kinks[] = {1000 / 203.0};
  ASSERT_TRUE(check_tone_kinks(*f, **curve, xs, "bt2390", kinks).passed) << check_tone_kinks(*f, **curve, xs, "bt2390", kinks).detail;
  for (auto& v : f->signal16) v = static_cast<std::uint16_t>(v - 11);  // the corner's old error: 11 steps low
  const Check c = check_tone_kinks(*f, **curve, xs, "bt2390", kinks);
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find("16-bit steps off"), std::string::npos) << c.detail;
}

TEST(BrokenEncoder, BlackFrameSayingZeroSomewhereFails) {
  const EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 0.0);
  nlohmann::json sidecar = io::sidecar_json(f, {});
  auto png = io::read_png_info_memory(*io::encode_png(f));
  ASSERT_TRUE(png.ok());
  const auto blob = display::serialize(*display::make_hdr_output_metadata(Mode::hdr10, f.mastering, f.content_light));
  ASSERT_TRUE(check_black_frame_metadata(f, sidecar, &*png, blob).passed)
      << check_black_frame_metadata(f, sidecar, &*png, blob).detail;
  sidecar["content_light_level"]["max_cll_nits"] = 0;  // the old sidecar: 0 / 0
  sidecar["content_light_level"]["max_fall_nits"] = 0;
  const Check c = check_black_frame_metadata(f, sidecar, &*png, blob);
  EXPECT_FALSE(c.passed);
  EXPECT_NE(c.detail.find("sidecar says 0/0, want 1000/1000"), std::string::npos) << c.detail;
}

TEST(BrokenEncoder, UiDecodedWithTheWrongSdrEotfFails) {
  const int codes[] = {0, 5, 10, 20, 51, 255};
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 24;
  overlay->height = 2;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 24; ++x) {
      const float v = codes[x / 4] / 255.0f;
      overlay->rgba.insert(overlay->rgba.end(), {v, v, v, 1.0f});
    }
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.target.sdr_content_eotf = SdrEotf::gamma22;
  s.tone.curve = "clip";
  s.ui.overlay = overlay;
  Image black(24, 2);
  SceneInput in;
  in.image = &black;
  auto f = encode_frame(in, s);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(check_sdr_content(*f, codes, 203).passed) << check_sdr_content(*f, codes, 203).detail;
  f->target.sdr_content_eotf = SdrEotf::srgb;  // the frame claims sRGB: the shadows disagree
  const Check c = check_sdr_content(*f, codes, 203);
  EXPECT_FALSE(c.passed);
  EXPECT_EQ(c.name, "sdr-content/srgb");
}

// The whole suite over a deliberately broken encoder (every code two too high, after an
// otherwise correct encode): the report fails, and it fails on the checks that measure
// codes, not on ones that cannot see the frames (the tone curves' monotonicity).
TEST(BrokenEncoder, WholeSuiteFailsForTheRightChecks) {
  SuiteOptions o;
  o.render = false;
  const DisplayTarget t = default_target(Mode::hdr10);
  const Report good = run_suite(t, "hdr10", o);
  ASSERT_TRUE(good.passed()) << good.to_json().dump(1);
  o.tamper = [](EncodedFrame& f) { shift_codes(f, 2); };
  const Report bad = run_suite(t, "hdr10", o);
  EXPECT_FALSE(bad.passed());
  std::map<std::string, const Check*> by_name;
  for (const auto& c : bad.checks) by_name[c.name] = &c;
  for (const char* name : {"paper-white/clip", "window/203", "window/1000", "peak/ramp-clip", "content-light/ramp-clip",
                           "metadata-blob", "display-volume/clip", "tone-kinks/clip", "tone-kinks/bt2390",
                           "sdr-content/srgb", "sdr-shadows/rows"}) {
    ASSERT_TRUE(by_name.count(name)) << name;
    EXPECT_FALSE(by_name[name]->passed) << name << ": " << by_name[name]->detail;
  }
  EXPECT_NE(by_name["paper-white/clip"]->detail.find("(596, 596, 596) vs 594"), std::string::npos)
      << by_name["paper-white/clip"]->detail;
  int curve_checks = 0;
  for (const auto& c : bad.checks)
    if (c.name.rfind("monotonic/", 0) == 0) {
      EXPECT_TRUE(c.passed) << c.name;
      ++curve_checks;
    }
  EXPECT_GT(curve_checks, 3);
  EXPECT_EQ(bad.to_json()["passed"], false);
}

TEST(BrokenEncoder, SuiteReportFailsWhenOneCheckFails) {
  Report r;
  r.checks.push_back(Check{"a", "s", true, false, ""});
  r.checks.push_back(Check{"b", "s", false, true, "skipped"});
  EXPECT_TRUE(r.passed());
  r.checks.push_back(Check{"c", "s", false, false, "broken"});
  EXPECT_FALSE(r.passed());
  EXPECT_EQ(r.to_json()["failed"], 1);
}

}  // namespace
}  // namespace hdrd::patterns

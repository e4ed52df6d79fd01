// The suite's checks fail on broken frames: codes off by N, codes above the peak,
// wrong content light, corrupted metadata bytes and PNG chunks. Each broken input is
// made from a good frame, which the same check passes first.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "display/hdr_metadata.hpp"
#include "encode/io.hpp"
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
  shift_codes(f, -3);
  EXPECT_FALSE(check_paper_white(f, "clip").passed);
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
  EXPECT_FALSE(check_peak(f, "t").passed);
}

TEST(BrokenEncoder, WrongContentLightFails) {
  EncodedFrame f = encode_uniform(default_target(Mode::hdr10), 2.0);
  ASSERT_TRUE(check_content_light(f, "t").passed) << check_content_light(f, "t").detail;
  f.content_light.max_cll_nits *= 1.05;
  EXPECT_FALSE(check_content_light(f, "t").passed);
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
  EXPECT_FALSE(check_window(*f, 400).passed);
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

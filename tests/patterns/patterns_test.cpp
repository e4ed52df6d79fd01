// Display-referred patterns: levels land on the codes the standards give them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>

#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "encode/colour/transfer.hpp"
#include "patterns/decode.hpp"
#include "patterns/font.hpp"
#include "patterns/patterns.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::patterns {
namespace {

int code_at(const EncodedFrame& f, int x, int y) { return read_pixel(f, x, y).code[1]; }

PatternOptions small(int w = 320, int h = 180) {
  PatternOptions o;
  o.width = w, o.height = h;
  return o;
}

// The window's centre is within one code of the requested luminance (ST 2084 inverse
// EOTF, 10-bit full range), and it covers the requested share of the frame.
TEST(Window, LevelWithinOneCodeAndAreaAsRequested) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.peak_nits = 4000;
  for (double level : {0.5, 100.0, 203.0, 1000.0, 4000.0})
    for (double area : {1.0, 2.0, 10.0, 25.0, 50.0, 100.0}) {
      PatternOptions o = small();
      o.level_nits = level, o.area_percent = area;
      auto f = make_pattern("window", t, o, false);
      ASSERT_TRUE(f) << f.error().message;
      const int want = transfer::quantize_full(transfer::pq_inverse_eotf(level), 10);
      EXPECT_LE(std::abs(code_at(*f, 160, 90) - want), 1) << level << " cd/m2, " << area << " %";
      int lit = 0;
      for (int y = 0; y < 180; ++y)
        for (int x = 0; x < 320; ++x) lit += code_at(*f, x, y) == code_at(*f, 160, 90);
      EXPECT_NEAR(100.0 * lit / (320 * 180), area, 0.5) << area;
    }
}

// The same against published codes rather than the transfer functions the encoder uses:
// REFERENCE.md §2 (PQ table) and ../shared/reference/published_vectors.md §3, 10-bit
// PQ codes for full and narrow range, at every window area.
TEST(Window, HitsThePublishedPqCodesWithinOneCode) {
  struct Published {
    double nits;
    int full, narrow;
  };
  const Published table[] = {{0.1, 64, 119}, {1, 153, 195}, {100, 520, 509}, {203, 594, 573},
                             {400, 668, 636}, {1000, 769, 723}, {4000, 923, 855}};
  for (Range range : {Range::full, Range::narrow}) {
    DisplayTarget t = default_target(Mode::hdr10);
    t.peak_nits = 4000;
    t.range = range;
    for (const auto& p : table)
      for (double area : {1.0, 2.0, 10.0, 25.0, 50.0, 100.0}) {
        PatternOptions o = small();
        o.level_nits = p.nits, o.area_percent = area;
        auto f = make_pattern("window", t, o, false);
        ASSERT_TRUE(f) << f.error().message;
        const int want = range == Range::full ? p.full : p.narrow;
        for (int c : read_pixel(*f, 160, 90).code)
          EXPECT_LE(std::abs(c - want), 1) << p.nits << " cd/m2, " << to_string(range) << ", " << area << " %";
      }
  }
}

TEST(Window, Bt2408ReferenceWhiteIsCode594) {
  PatternOptions o = small();
  o.level_nits = 203;
  auto f = make_pattern("window", default_target(Mode::hdr10), o, false);
  ASSERT_TRUE(f);
  EXPECT_EQ(code_at(*f, 160, 90), 594);  // BT.2408-7: 203 cd/m2 = PQ 58 % = 594 (10-bit full)
}

TEST(Window, AboveThePeakIsClippedAndSaid) {
  PatternOptions o = small();
  o.level_nits = 2000;
  auto f = make_pattern("window", default_target(Mode::hdr10), o, false);
  ASSERT_TRUE(f);
  EXPECT_EQ(code_at(*f, 160, 90), transfer::quantize_full(transfer::pq_inverse_eotf(1000), 10));
  EXPECT_TRUE(f->settings["pattern"].contains("note"));
  o.area_percent = 0;
  EXPECT_FALSE(make_pattern("window", default_target(Mode::hdr10), o, false));
}

// Equal PQ steps: step k of 11 is E' = k/10, so its 10-bit full-range code is a nearest
// code to 102.3 k (k = 5 is a tie: 511 or 512).
TEST(PqRamp, StepsAreEqualPqSignal) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.peak_nits = 10000;
  auto f = make_pattern("pq-ramp", t, small(440, 100), false);
  ASSERT_TRUE(f);
  for (int k = 0; k <= 10; ++k) EXPECT_NEAR(code_at(*f, 20 + 40 * k, 10), 102.3 * k, 0.5 + 1e-9) << k;
}

TEST(PqRamp, LabelsAreDrawnInTheStrip) {
  DisplayTarget t = default_target(Mode::hdr10);
  auto f = make_pattern("pq-ramp", t, small(1100, 200), false);
  ASSERT_TRUE(f);
  int lit = 0;
  for (int y = 160; y < 200; ++y)
    for (int x = 0; x < 1100; ++x) lit += code_at(*f, x, y) > 0;
  EXPECT_GT(lit, 100);  // the "10000" etc. glyphs
  PatternOptions o = small(1100, 200);
  o.labels = false;
  auto g = make_pattern("pq-ramp", t, o, false);
  int lit2 = 0;
  for (int y = 160; y < 200; ++y)
    for (int x = 0; x < 1100; ++x) lit2 += code_at(*g, x, y) > 0;
  EXPECT_EQ(lit2, 0);
}

// HGIG-style clipping: encoded for a display whose peak is P, the squares at or above P
// equal the background and the ones below stay visible.
TEST(Clipping, DetailVanishesExactlyAtThePeak) {
  for (double peak : {600.0, 1000.0}) {
    DisplayTarget t = default_target(Mode::hdr10);
    t.peak_nits = peak;
    PatternOptions o = small(900, 200);
    o.level_nits = peak;
    auto f = make_pattern("clipping", t, o, false);
    ASSERT_TRUE(f);
    const auto squares = f->settings["pattern"]["square_nits"];
    ASSERT_EQ(squares.size(), 9u);
    const int background = code_at(*f, 2, 2);
    for (int i = 0; i < 9; ++i) {
      const int c = code_at(*f, 50 + 100 * i, 80);
      if (squares[i].get<double>() >= peak) { EXPECT_EQ(c, background) << squares[i]; }
      else EXPECT_LT(c, background) << squares[i];
    }
  }
}

TEST(NearBlack, StepsAreDistinctCodesInPq) {
  auto f = make_pattern("near-black", default_target(Mode::hdr10), small(1000, 200), false);
  ASSERT_TRUE(f);
  int prev = code_at(*f, 2, 2);  // 0 cd/m2 background
  EXPECT_EQ(prev, 0);
  for (int i = 0; i < 10; ++i) {
    const int c = code_at(*f, 50 + 100 * i, 80);
    EXPECT_GT(c, prev) << i;
    prev = c;
  }
}

// SDR white in an HDR frame at 203 cd/m2 is PQ code 594 (BT.2408-7).
TEST(SdrGrey, WhiteAtSdrWhite) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.sdr_white_nits = 203;
  auto f = make_pattern("sdr-grey", t, small(1100, 100), false);
  ASSERT_TRUE(f);
  EXPECT_EQ(code_at(*f, 1050, 10), 594);
  EXPECT_EQ(code_at(*f, 10, 10), 0);
  // SDR mode: the 100 % step is the SDR white code, 40 % sRGB signal is code 102 (8-bit).
  auto s = make_pattern("sdr-grey", default_target(Mode::sdr), small(1100, 100), false);
  ASSERT_TRUE(s);
  EXPECT_EQ(code_at(*s, 1050, 10), 255);
  EXPECT_EQ(code_at(*s, 450, 10), 102);
}

TEST(Font, GlyphsAreDistinctAndSized) {
  EXPECT_NE(std::memcmp(glyph('0'), glyph('8'), kGlyphHeight), 0);
  EXPECT_EQ(std::memcmp(glyph('a'), glyph('A'), kGlyphHeight), 0);
  EXPECT_EQ(text_width("10000", 2), (5 * 6 - 1) * 2);
  int lit = 0;
  draw_text("1", 0, 0, 1, [&](int, int) { ++lit; });
  EXPECT_EQ(lit, 10);  // the 5x7 "1": rows of 1, 2, 1, 1, 1, 1 and 3 pixels
}

TEST(PatternCli, WritesDumpsWithSidecar) {
  testing::TempDir dir;
  const auto out = dir / "win";
  auto r = testing::run_command(hdrd::testing::hdrd_binary().string() + " pattern window --mode hdr10 --level 400 " +
                                "--width 64 --height 36 -o " + out.string() + " --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(std::filesystem::exists(out.string() + ".png"));
  EXPECT_TRUE(std::filesystem::exists(out.string() + ".exr"));
  const auto side = nlohmann::json::parse(testing::read_file(out.string() + ".json"));
  EXPECT_EQ(side.dump().find("\"window\"") != std::string::npos, true);
  auto png = io::read_png_info(out.string() + ".png");
  ASSERT_TRUE(png);
  ASSERT_TRUE(png->cicp);
  EXPECT_EQ((*png->cicp)[1], 16);  // H.273 transfer 16 = PQ
  (void)j;
  auto bad = testing::run_command(hdrd::testing::hdrd_binary().string() + " pattern nope -o " + out.string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("unknown pattern"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace hdrd::patterns

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
#include "patterns/selftest.hpp"
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

// HGIG-style clipping (issue 29 item 9): the squares default to the display's peak P and are
// encoded over PQ's full range, so each square has its own code (ST 2084 computed here) and
// the display, not hdrd, decides which vanish into the 10000 cd/m2 background; the sidecar
// names the levels. hdrd clipped every square at or above P before (with --level = peak the
// upper half vanished whatever the display).
TEST(Clipping, SquaresAreEncodedOverTheSignalsFullRange) {
  auto pq = [](double nits) {
    const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
                 c3 = 2392.0 / 4096 * 32;
    const double y = std::pow(nits / 10000, m1);
    return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
  };
  for (double peak : {600.0, 1000.0}) {
    DisplayTarget t = default_target(Mode::hdr10);
    t.peak_nits = peak;
    auto f = make_pattern("clipping", t, small(900, 200), false);  // --level unset: the peak
    ASSERT_TRUE(f);
    const auto& desc = f->settings["pattern"];
    EXPECT_EQ(desc["level_nits"], peak);
    EXPECT_EQ(desc["display_peak_nits"], peak);
    EXPECT_EQ(desc["signal_peak_nits"], 10000);
    EXPECT_EQ(desc["background_nits"], 10000);
    EXPECT_FALSE(desc.contains("note"));
    const auto squares = desc["square_nits"];
    ASSERT_EQ(squares.size(), 9u);
    EXPECT_EQ(code_at(*f, 2, 2), 1023);
    int prev = 0;
    for (int i = 0; i < 9; ++i) {
      const int c = code_at(*f, 50 + 100 * i, 80);
      EXPECT_NEAR(c, pq(squares[i].get<double>()) * 1023, 0.5 + 1e-9) << squares[i];
      EXPECT_GT(c, prev) << squares[i];
      prev = c;
    }
  }
}

// Issue 29 item 2: the selftest's peak check is "no code decodes above the peak", not
// "no code above round(PQ(peak))": at 150 cd/m2 that nearest code, 562, decodes to
// 150.09 cd/m2 (ST 2084 computed here) and must fail; 561 passes.
TEST(SelftestPeak, NoCodeMayDecodeAboveThePeak) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.peak_nits = 150;
  auto frame = [&](int code) {
    return frame_from_codes(std::vector<Code3>(4, Code3{code, code, code}), 2, 2, t, false).value();
  };
  auto pq_eotf = [](double e) {
    const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
                 c3 = 2392.0 / 4096 * 32;
    const double p = std::pow(e, 1 / m2);
    return 10000 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1 / m1);
  };
  ASSERT_GT(pq_eotf(562 / 1023.0), 150);
  ASSERT_LE(pq_eotf(561 / 1023.0), 150);
  EXPECT_FALSE(check_peak(frame(562), "ramp").passed);
  EXPECT_TRUE(check_peak(frame(561), "ramp").passed);
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

// sdr-shadows: the same SDR shadow signals through sRGB, gamma 2.2 and BT.1886 (2.4), one row
// each at the SDR white; the codes are PQ of SDR white x EOTF(code / 255), written out here.
TEST(SdrShadows, RowsAreTheThreeEotfsAtSdrWhite) {
  DisplayTarget t = default_target(Mode::hdr10);
  t.sdr_white_nits = 203;
  t.sdr_content_eotf = SdrEotf::gamma22;
  const int w = 1200, h = 400;
  auto f = make_pattern("sdr-shadows", t, small(w, h), false);
  ASSERT_TRUE(f);
  const auto& signals = sdr_shadow_signals();
  ASSERT_EQ(signals.size(), 11u);
  auto pq = [](double nits) {
    const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
                 c3 = 2392.0 / 4096 * 32;
    const double y = std::pow(nits / 10000, m1);
    return static_cast<int>(std::lround(std::pow((c1 + c2 * y) / (1 + c3 * y), m2) * 1023));
  };
  const int label_w = w / 8, row_h = (h - h / 8) / 3, n = 11;
  for (int r = 0; r < 3; ++r)
    for (int i = 0; i < n; ++i) {
      const double v = signals[static_cast<std::size_t>(i)];
      const double rel = r == 0 ? (v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4))
                                : std::pow(v, r == 1 ? 2.2 : 2.4);
      const int x = label_w + (2 * i + 1) * (w - label_w) / (2 * n), y = r * row_h + row_h / 3;
      EXPECT_NEAR(code_at(*f, x, y), pq(203 * rel), 1) << "row " << r << " signal " << v;
    }
  // Code 10 (column 4) in the shadows: sRGB 0.616, gamma 2.2 0.163, BT.1886 0.085 cd/m2.
  const int x10 = label_w + 9 * (w - label_w) / (2 * n);
  EXPECT_GT(code_at(*f, x10, row_h / 3), code_at(*f, x10, row_h + row_h / 3));
  EXPECT_GT(code_at(*f, x10, row_h + row_h / 3), code_at(*f, x10, 2 * row_h + row_h / 3));
  EXPECT_EQ(f->settings["pattern"]["sdr_content_eotf"], "gamma22");
  EXPECT_EQ(f->settings["pattern"]["rows"], (nlohmann::json{"srgb", "gamma22", "bt1886"}));
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

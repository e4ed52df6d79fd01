// BT.2111 colour bars against the standard's code tables.
#include <gtest/gtest.h>

#include <cstring>

#include "patterns/patterns.hpp"

namespace hdrd::patterns {
namespace {

// ITU-R BT.2111-2 (12/2020), "Specification of colour bar test pattern for high dynamic
// range television systems": its tables of 10-bit narrow-range R'G'B' code values for the
// PQ bars and for the HLG bars, written out here as data, independently of the generator
// (which computes them from the signal levels: BT.2100 Table 9, D = round((219 E' + 16) 4)).
// Order: {PQ, HLG}.
//
// Provenance. The Recommendation itself is not among the references this project can read
// offline (../shared/reference has the BT.2100 Table 9 rule and the BT.2408 levels, not the
// BT.2111 tables), so the table numbers are not quoted here. Every value below was checked
// against two independent public transcriptions of the BT.2111-2 tables:
//  * ifb/vapoursynth-colorbars, colorbars.c (arrays hdr_p1_* .. hdr_p5_*: PQ and HLG,
//    10- and 12-bit, "used directly instead of being generated at runtime");
//  * yergin/test-pattern-descriptor, BT2111_HLG_10bit_narrow.tpat (the HLG pattern with its
//    1920-wide geometry), and the PQ/HLG values of a third implementation's acceptance test.
// They agree with each other and with this table code for code; the geometry of
// LayoutAt1920x1080 below (including the ramp, 5 ... 1018 one code per pixel) is the one
// the .tpat transcription gives.
struct Row {
  const char* level;
  Code3 pq, hlg;
};
const Row kTable[] = {
    {"40% grey", {414, 414, 414}, {414, 414, 414}},
    {"100% white", {940, 940, 940}, {940, 940, 940}},
    {"100% yellow", {940, 940, 64}, {940, 940, 64}},
    {"100% cyan", {64, 940, 940}, {64, 940, 940}},
    {"100% green", {64, 940, 64}, {64, 940, 64}},
    {"100% magenta", {940, 64, 940}, {940, 64, 940}},
    {"100% red", {940, 64, 64}, {940, 64, 64}},
    {"100% blue", {64, 64, 940}, {64, 64, 940}},
    {"ref white", {572, 572, 572}, {721, 721, 721}},
    {"ref grey", {572, 572, 572}, {721, 721, 721}},
    {"ref yellow", {572, 572, 64}, {721, 721, 64}},
    {"ref cyan", {64, 572, 572}, {64, 721, 721}},
    {"ref green", {64, 572, 64}, {64, 721, 64}},
    {"ref magenta", {572, 64, 572}, {721, 64, 721}},
    {"ref red", {572, 64, 64}, {721, 64, 64}},
    {"ref blue", {64, 64, 572}, {64, 64, 721}},
    {"-7% grey", {4, 4, 4}, {4, 4, 4}},
    {"0% grey", {64, 64, 64}, {64, 64, 64}},
    {"10% grey", {152, 152, 152}, {152, 152, 152}},
    {"20% grey", {239, 239, 239}, {239, 239, 239}},
    {"30% grey", {327, 327, 327}, {327, 327, 327}},
    {"50% grey", {502, 502, 502}, {502, 502, 502}},
    {"60% grey", {590, 590, 590}, {590, 590, 590}},
    {"70% grey", {677, 677, 677}, {677, 677, 677}},
    {"80% grey", {765, 765, 765}, {765, 765, 765}},
    {"90% grey", {852, 852, 852}, {852, 852, 852}},
    {"100% grey", {940, 940, 940}, {940, 940, 940}},
    {"109% grey", {1019, 1019, 1019}, {1019, 1019, 1019}},
    {"-2% grey", {48, 48, 48}, {48, 48, 48}},
    {"+2% grey", {80, 80, 80}, {80, 80, 80}},
    {"+4% grey", {99, 99, 99}, {99, 99, 99}},
    // The BT.709 bars in the BT.2020 container.
    {"709 yellow", {568, 571, 381}, {713, 719, 316}},
    {"709 cyan", {484, 566, 571}, {538, 709, 718}},
    {"709 green", {474, 564, 368}, {512, 706, 296}},
    {"709 magenta", {536, 361, 564}, {651, 286, 705}},
    {"709 red", {530, 350, 256}, {639, 269, 164}},
    {"709 blue", {317, 236, 562}, {227, 147, 702}},
};

TEST(Bt2111, LevelCodesEqualTheStandardsTables) {
  for (const auto& row : kTable) {
    EXPECT_EQ(bt2111_code(Bt2111System::pq, row.level), row.pq) << "PQ " << row.level;
    EXPECT_EQ(bt2111_code(Bt2111System::hlg, row.level), row.hlg) << "HLG " << row.level;
  }
}

TEST(Bt2111, EveryLevelThePatternUsesIsInTheTable) {
  for (const auto& level : bt2111_levels()) {
    bool found = false;
    for (const auto& row : kTable) found = found || level == row.level;
    EXPECT_TRUE(found) << level;
  }
}

Code3 at(const std::vector<Code3>& c, int x, int y) { return c[static_cast<std::size_t>(y) * 1920 + x]; }
Code3 grey(int code) { return {code, code, code}; }

// BT.2111-2 layout at 1920x1080: rows of 90, 540, 90, 90 and 270 lines.
TEST(Bt2111, LayoutAt1920x1080) {
  for (auto sys : {Bt2111System::pq, Bt2111System::hlg}) {
    const auto codes = bt2111_codes(sys, 1920, 1080);
    const int ref = sys == Bt2111System::pq ? 572 : 721;
    EXPECT_EQ(at(codes, 100, 45), (Code3{414, 414, 414}));        // 40 % side panel
    EXPECT_EQ(at(codes, 240 + 103, 45), (Code3{940, 940, 940}));  // 100 % white
    EXPECT_EQ(at(codes, 1920 - 240 - 103, 45), (Code3{64, 64, 940}));  // 100 % blue
    EXPECT_EQ(at(codes, 240 + 206 + 103, 89), (Code3{940, 940, 64}));  // last line of row 1
    EXPECT_EQ(at(codes, 240 + 206 + 103, 90), (Code3{ref, ref, 64}));  // first line of row 2
    EXPECT_EQ(at(codes, 240 + 206 + 103, 629), (Code3{ref, ref, 64}));
    EXPECT_EQ(at(codes, 240 + 103, 675), (Code3{4, 4, 4}));            // -7 % in row 3
    EXPECT_EQ(at(codes, 1920 - 240 - 50, 675), (Code3{1019, 1019, 1019}));
    EXPECT_EQ(at(codes, 100, 765), (Code3{64, 64, 64}));               // row 4: 0 % black,
    EXPECT_EQ(at(codes, 240, 765), (Code3{4, 4, 4}));                  // -7 % from x = 240,
    EXPECT_EQ(at(codes, 240 + 559 - 1, 765), (Code3{4, 4, 4}));
    for (int x = 240 + 559; x < 240 + 559 + 1014; ++x)                 // the ramp 5 ... 1018,
      ASSERT_EQ(at(codes, x, 765), grey(5 + x - (240 + 559))) << "ramp at x = " << x;
    EXPECT_EQ(at(codes, 240 + 559 + 1014, 765), (Code3{1019, 1019, 1019}));  // then 109 %
    EXPECT_EQ(at(codes, 1919, 765), (Code3{1019, 1019, 1019}));
    EXPECT_EQ(at(codes, 40, 1000), bt2111_code(sys, "709 yellow"));
    EXPECT_EQ(at(codes, 1920 - 40, 1000), bt2111_code(sys, "709 blue"));
    EXPECT_EQ(at(codes, 240 + 136 + 35, 1000), (Code3{48, 48, 48}));  // -2 % PLUGE
    EXPECT_EQ(at(codes, 240 + 136 + 70 + 68 + 35, 1000), (Code3{80, 80, 80}));
    EXPECT_EQ(at(codes, 240 + 136 + 346 + 238 + 219, 1000), (Code3{ref, ref, ref}));
  }
}

TEST(Bt2111, PatternFrameIsNarrowRangeWithTheCodesAndMetadata) {
  DisplayTarget t = default_target(Mode::hdr10);
  PatternOptions o;
  o.width = 192, o.height = 108;
  auto f = make_pattern("bt2111", t, o);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->target.range, Range::narrow);
  std::uint32_t w;
  std::memcpy(&w, f->data.data() + (5 * 192 + 10) * 4, 4);  // row 1, side panel
  EXPECT_EQ(w & 1023, 414u);
  // 100 % PQ is 10000 cd/m2: MaxCLL of the bars is the PQ maximum decoded from code 1019.
  EXPECT_GT(f->content_light.max_cll_nits, 9000);
  EXPECT_FALSE(make_pattern("bt2111", default_target(Mode::sdr), o));
}

}  // namespace
}  // namespace hdrd::patterns

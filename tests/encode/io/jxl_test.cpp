// JPEG XL: jxlinfo (libjxl-tools) reports the colour encoding and intensity_target hdrd means,
// djxl decodes lossless files to exactly the samples of the PNG of the same frame, and lossy
// ones to a signal close to the frame's.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include <gtest/gtest.h>

#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"
#include "tests/encode/io/stills_testing.hpp"

namespace hdrd::io {
namespace {

using stilltest::line_with;
using testing::TempDir;

const Image& small_scene() {
  static const Image img = stilltest::scene(96, 64);
  return img;
}

struct JxlCase {
  std::string name;
  Mode mode;
  double peak_nits;
  bool lossless;
  std::string colour;  // jxlinfo's "Color space:" line
  std::string depth;   // jxlinfo's first line
};
void PrintTo(const JxlCase& c, std::ostream* os) { *os << c.name; }

std::vector<JxlCase> jxl_cases() {
  return {
      {"Hdr10Lossy", Mode::hdr10, 1000, false,
       "Color space: RGB, D65, Rec.2100 primaries, PQ transfer function, rendering intent: Relative", "lossy, 16-bit RGB"},
      {"Hdr10Lossless600", Mode::hdr10, 600, true,
       "Color space: RGB, D65, Rec.2100 primaries, PQ transfer function, rendering intent: Relative",
       "(possibly) lossless, 16-bit RGB"},
      {"HlgLossy", Mode::hlg, 1000, false,
       "Color space: RGB, D65, Rec.2100 primaries, HLG transfer function, rendering intent: Relative", "lossy, 16-bit RGB"},
      {"SdrLossless", Mode::sdr, 100, true,
       "Color space: RGB, D65, sRGB primaries, sRGB transfer function, rendering intent: Relative",
       "(possibly) lossless, 8-bit RGB"},
  };
}

class JxlFile : public ::testing::TestWithParam<JxlCase> {};

TEST_P(JxlFile, JxlinfoReportsTheColourEncodingAndIntensityTarget) {
  HDRD_REQUIRE_TOOL("jxlinfo", "libjxl-tools");
  const JxlCase& c = GetParam();
  const Image& img = small_scene();
  EncodedFrame f = stilltest::rendition(img, c.mode);
  f.target.peak_nits = c.peak_nits;  // what the file must carry as intensity_target
  JxlOptions o;
  o.lossless = c.lossless;
  TempDir tmp;
  ASSERT_TRUE(write_jxl(tmp / "f.jxl", f, o).ok());
  const auto info = testing::run_command("jxlinfo " + (tmp / "f.jxl").string());
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("96x64, " + c.depth), std::string::npos) << info.out;
  EXPECT_EQ(line_with(info.out, "Color space:"), c.colour) << info.out;
  EXPECT_EQ(line_with(info.out, "intensity_target:"), fmt::format("intensity_target: {:.6f} nits", c.peak_nits));
}

INSTANTIATE_TEST_SUITE_P(Cases, JxlFile, ::testing::ValuesIn(jxl_cases()),
                         [](const ::testing::TestParamInfo<JxlCase>& i) { return i.param.name; });

// djxl writes the stored samples of a lossless file to its PNG unchanged: they must be the PNG's.
TEST(JxlLossless, DecodesToThePngSamplesOfTheSameFrame) {
  HDRD_REQUIRE_TOOL("djxl", "libjxl-tools");
  for (Mode mode : {Mode::hdr10, Mode::hlg, Mode::sdr}) {
    SCOPED_TRACE(std::string(to_string(mode)));
    const EncodedFrame f = stilltest::rendition(small_scene(), mode);  // with signal16
    JxlOptions o;
    o.lossless = true;
    TempDir tmp;
    ASSERT_TRUE(write_jxl(tmp / "f.jxl", f, o).ok());
    ASSERT_TRUE(write_png(tmp / "f.png", f).ok());
    const auto dec = testing::run_command("djxl " + (tmp / "f.jxl").string() + " " + (tmp / "d.png").string());
    ASSERT_EQ(dec.exit_code, 0) << dec.err;
    const auto want = read_png_info(tmp / "f.png");
    const auto got = read_png_info(tmp / "d.png");
    ASSERT_TRUE(want.ok() && got.ok());
    ASSERT_EQ(got->bit_depth, want->bit_depth);
    ASSERT_EQ(got->channels, 3);
    EXPECT_TRUE(got->samples == want->samples);
  }
}

// A narrow-range frame is written as the full-range signal its codes stand for (JPEG XL has no
// narrow range): E' = (D / 4 - 16) / 219 (BT.2100 Table 9), stored as round(E' 65535).
TEST(JxlLossless, NarrowFrameBecomesItsFullRangeSignal) {
  HDRD_REQUIRE_TOOL("djxl", "libjxl-tools");
  const EncodedFrame f = stilltest::rendition(small_scene(), Mode::hdr10, Range::narrow);
  JxlOptions o;
  o.lossless = true;
  TempDir tmp;
  ASSERT_TRUE(write_jxl(tmp / "f.jxl", f, o).ok());
  ASSERT_EQ(testing::run_command("djxl " + (tmp / "f.jxl").string() + " " + (tmp / "d.png").string()).exit_code, 0);
  const auto got = read_png_info(tmp / "d.png");
  ASSERT_TRUE(got.ok());
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      std::uint32_t word;
      std::memcpy(&word, f.data.data() + y * f.stride_bytes + x * 4, 4);
      for (int c = 0; c < 3; ++c) {
        const double e = std::clamp((((word >> (10 * c)) & 1023) / 4.0 - 16.0) / 219.0, 0.0, 1.0);
        ASSERT_EQ(got->samples[(static_cast<std::size_t>(y) * f.width + x) * 3 + c], std::lround(e * 65535))
            << x << "," << y << " c" << c;
      }
    }
}

TEST(JxlLossy, DecodedSignalStaysCloseToTheFrame) {
  HDRD_REQUIRE_TOOL("djxl", "libjxl-tools");
  const EncodedFrame f = stilltest::rendition(small_scene(), Mode::hdr10);
  TempDir tmp;
  ASSERT_TRUE(write_jxl(tmp / "f.jxl", f).ok());  // quality 90: butteraugli distance 1
  ASSERT_TRUE(write_png(tmp / "f.png", f).ok());
  ASSERT_EQ(testing::run_command("djxl " + (tmp / "f.jxl").string() + " " + (tmp / "d.png").string()).exit_code, 0);
  const auto want = read_png_info(tmp / "f.png");
  const auto got = read_png_info(tmp / "d.png");
  ASSERT_TRUE(want.ok() && got.ok());
  ASSERT_EQ(got->samples.size(), want->samples.size());
  double mean = 0;
  for (std::size_t i = 0; i < want->samples.size(); ++i) mean += std::abs(double(got->samples[i]) - want->samples[i]);
  mean /= 65535.0 * want->samples.size();
  EXPECT_LT(mean, 0.004);  // of full scale: a few 10-bit codes on average
}

TEST(JxlErrors, NameWhatIsWrong) {
  const EncodedFrame hdr = stilltest::rendition(small_scene(), Mode::hdr10);
  JxlOptions o;
  o.quality = -1;
  auto r = encode_jxl(hdr, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "jxl.quality");
  o = {};
  o.effort = 0;
  r = encode_jxl(hdr, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "jxl.effort");
  r = encode_jxl(stilltest::rendition(small_scene(), Mode::scrgb));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "jxl.unsupported");
}

}  // namespace
}  // namespace hdrd::io

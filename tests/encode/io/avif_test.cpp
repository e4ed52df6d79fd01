// AVIF: Debian's own readers say what the files are (avifdec --info from libavif-bin, ffprobe
// from FFmpeg, heif-info from libheif for clli/mdcv), lossless files decode (avifdec) to the
// samples of the PNG of the same frame, and the container boxes are checked byte by byte with
// the test's own ISOBMFF walker against values worked out from ST 2086 / CTA-861.3 by hand.
#include <cmath>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"
#include "tests/encode/io/stills_testing.hpp"

namespace hdrd::io {
namespace {

using stilltest::Bytes;
using stilltest::line_with;
using testing::TempDir;

const Image& small_scene() {
  static const Image img = stilltest::scene(96, 64);
  return img;
}

struct AvifCase {
  std::string name;
  Mode mode;
  Range frame_range;
  AvifOptions options;
  // what avifdec --info must report
  int depth;
  std::string format, range;
  int primaries, transfer, matrix;
};
void PrintTo(const AvifCase& c, std::ostream* os) { *os << c.name; }

std::vector<AvifCase> avif_cases() {
  AvifOptions lossless;
  lossless.lossless = true;
  AvifOptions twelve;
  twelve.bits = 12;
  twelve.chroma = ChromaSubsampling::yuv444;
  AvifOptions to_narrow;
  to_narrow.range = Range::narrow;
  AvifOptions rgb_lossy;
  rgb_lossy.matrix = AvifMatrix::rgb;
  AvifOptions c422;
  c422.chroma = ChromaSubsampling::yuv422;
  return {
      {"Hdr10Yuv420Default", Mode::hdr10, Range::full, {}, 10, "YUV420", "Full", 9, 16, 9},
      {"Hdr10Lossless", Mode::hdr10, Range::full, lossless, 10, "YUV444", "Full", 9, 16, 0},
      {"Hdr10Twelve444", Mode::hdr10, Range::full, twelve, 12, "YUV444", "Full", 9, 16, 9},
      {"Hdr10ToNarrow", Mode::hdr10, Range::full, to_narrow, 10, "YUV420", "Limited", 9, 16, 9},
      {"Hdr10NarrowFrameLossless", Mode::hdr10, Range::narrow, lossless, 10, "YUV444", "Limited", 9, 16, 0},
      {"HlgYuv422", Mode::hlg, Range::full, c422, 10, "YUV422", "Full", 9, 18, 9},
      {"HlgRgbLossy", Mode::hlg, Range::full, rgb_lossy, 10, "YUV444", "Full", 9, 18, 0},
      {"SdrEightBit", Mode::sdr, Range::full, {}, 8, "YUV420", "Full", 1, 13, 1},
      {"SdrBt1886Lossless", Mode::sdr_bt1886, Range::full, lossless, 8, "YUV444", "Full", 1, 1, 0},
  };
}

class AvifFile : public ::testing::TestWithParam<AvifCase> {};

TEST_P(AvifFile, DecodersReportTheCodePoints) {
  HDRD_REQUIRE_TOOL("avifdec", "libavif-bin");
  const AvifCase& c = GetParam();
  const EncodedFrame f = stilltest::rendition(small_scene(), c.mode, c.frame_range);
  const auto avif = encode_avif(f, c.options);
  ASSERT_TRUE(avif.ok()) << avif.error().message;
  TempDir tmp;
  stilltest::write_bytes(tmp / "f.avif", *avif);
  const auto info = testing::run_command("avifdec --info " + (tmp / "f.avif").string());
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(line_with(info.out, "Resolution").find("96x64"), std::string::npos) << info.out;
  EXPECT_NE(line_with(info.out, "Bit Depth").find(std::to_string(c.depth)), std::string::npos) << info.out;
  EXPECT_NE(line_with(info.out, "Format").find(c.format), std::string::npos) << info.out;
  EXPECT_NE(line_with(info.out, "Range").find(c.range), std::string::npos) << info.out;
  EXPECT_EQ(line_with(info.out, "Color Primaries"), " * Color Primaries: " + std::to_string(c.primaries));
  EXPECT_EQ(line_with(info.out, "Transfer Char."), " * Transfer Char. : " + std::to_string(c.transfer));
  EXPECT_EQ(line_with(info.out, "Matrix Coeffs."), " * Matrix Coeffs. : " + std::to_string(c.matrix));
}

class AvifProbe : public ::testing::TestWithParam<AvifCase> {};

TEST_P(AvifProbe, FfprobeReadsTheSameColourDescription) {
  HDRD_REQUIRE_TOOL("ffprobe", "ffmpeg");
  const AvifCase& c = GetParam();
  const EncodedFrame f = stilltest::rendition(small_scene(), c.mode, c.frame_range);
  const auto avif = encode_avif(f, c.options);
  ASSERT_TRUE(avif.ok()) << avif.error().message;
  TempDir tmp;
  stilltest::write_bytes(tmp / "f.avif", *avif);
  const auto probe = testing::run_command("ffprobe -v error -show_streams " + (tmp / "f.avif").string());
  ASSERT_EQ(probe.exit_code, 0) << probe.err;
  // FFmpeg's names for the H.273 code points (libavutil/pixfmt.h).
  const std::map<int, std::string> primaries{{1, "bt709"}, {9, "bt2020"}};
  const std::map<int, std::string> transfer{{1, "bt709"}, {13, "iec61966-2-1"}, {16, "smpte2084"}, {18, "arib-std-b67"}};
  const std::map<int, std::string> matrix{{0, "gbr"}, {1, "bt709"}, {9, "bt2020nc"}};
  EXPECT_EQ(line_with(probe.out, "color_primaries="), "color_primaries=" + primaries.at(c.primaries));
  EXPECT_EQ(line_with(probe.out, "color_transfer="), "color_transfer=" + transfer.at(c.transfer));
  EXPECT_EQ(line_with(probe.out, "color_space="), "color_space=" + matrix.at(c.matrix));
  EXPECT_EQ(line_with(probe.out, "color_range="), std::string("color_range=") + (c.range == "Full" ? "pc" : "tv"));
}

std::string case_name(const ::testing::TestParamInfo<AvifCase>& i) { return i.param.name; }
INSTANTIATE_TEST_SUITE_P(Cases, AvifFile, ::testing::ValuesIn(avif_cases()), case_name);
// ffprobe takes ~0.7 s to start: the cases that cover every code point and range it names.
std::vector<AvifCase> probe_cases() {
  std::vector<AvifCase> out;
  for (const AvifCase& c : avif_cases())
    if (c.name == "Hdr10Lossless" || c.name == "Hdr10ToNarrow" || c.name == "HlgYuv422" || c.name == "SdrEightBit" ||
        c.name == "SdrBt1886Lossless")
      out.push_back(c);
  return out;
}
INSTANTIATE_TEST_SUITE_P(Cases, AvifProbe, ::testing::ValuesIn(probe_cases()), case_name);


// avifdec widens 10-bit codes to 16-bit PNG samples as D 65535 / 1023 in float, hdrd's PNG of a
// frame without signal16 as round(D 65535 / 1023) in integers (docs/dump-format.md §3); the two
// differ by 1 where D 65535 / 1023 lies within float error of .5 (820 -> 52530.4985). So the
// samples are compared as the codes they stand for: round(s 1023 / 65535) is exact for both.
TEST(AvifLossless, DecodesToThePngSamplesOfTheSameFrame) {
  HDRD_REQUIRE_TOOL("avifdec", "libavif-bin");
  for (Mode mode : {Mode::hdr10, Mode::hlg, Mode::sdr}) {
    SCOPED_TRACE(std::string(to_string(mode)));
    const EncodedFrame f = stilltest::rendition(small_scene(), mode, Range::full, false);
    AvifOptions o;
    o.lossless = true;
    TempDir tmp;
    ASSERT_TRUE(write_avif(tmp / "f.avif", f, o).ok());
    ASSERT_TRUE(write_png(tmp / "f.png", f).ok());
    const auto dec = testing::run_command("avifdec " + std::string(mode == Mode::sdr ? "-d 8 " : "-d 16 ") +
                                          (tmp / "f.avif").string() + " " + (tmp / "dec.png").string());
    ASSERT_EQ(dec.exit_code, 0) << dec.err;
    const auto want = read_png_info(tmp / "f.png");
    const auto got = read_png_info(tmp / "dec.png");
    ASSERT_TRUE(want.ok() && got.ok());
    ASSERT_EQ(got->bit_depth, want->bit_depth);
    ASSERT_EQ(got->channels, 3);
    ASSERT_EQ(got->samples.size(), want->samples.size());
    const auto code = [&](std::uint16_t s) { return mode == Mode::sdr ? s : std::lround(s * 1023.0 / 65535.0); };
    std::size_t differ = 0, first = 0;
    for (std::size_t i = 0; i < want->samples.size(); ++i)
      if (code(got->samples[i]) != code(want->samples[i]) && differ++ == 0) first = i;
    EXPECT_EQ(differ, 0u) << "first at sample " << first << ": " << got->samples[first] << " vs " << want->samples[first];
  }
}

// Lossy files keep the picture: the decoded signal stays close to the frame's, which also shows
// that the Y'CbCr matrix libavif applied is the one the file signals (a wrong one tints).
TEST(AvifLossy, DecodedSignalStaysCloseToTheFrame) {
  HDRD_REQUIRE_TOOL("avifdec", "libavif-bin");
  const EncodedFrame f = stilltest::rendition(small_scene(), Mode::hdr10, Range::full, false);
  for (int quality : {60, 90}) {
    AvifOptions o;
    o.quality = quality;
    TempDir tmp;
    ASSERT_TRUE(write_avif(tmp / "f.avif", f, o).ok());
    ASSERT_TRUE(write_png(tmp / "f.png", f).ok());
    ASSERT_EQ(testing::run_command("avifdec -d 16 " + (tmp / "f.avif").string() + " " + (tmp / "d.png").string())
                  .exit_code,
              0);
    const auto want = read_png_info(tmp / "f.png");
    const auto got = read_png_info(tmp / "d.png");
    ASSERT_TRUE(want.ok() && got.ok());
    std::array<double, 3> mean_error{};
    for (std::size_t i = 0; i < want->samples.size(); ++i)
      mean_error[i % 3] += std::abs(double(got->samples[i]) - want->samples[i]) / 65535.0;
    for (double& e : mean_error) e /= want->samples.size() / 3.0;
    const double limit = quality >= 90 ? 0.004 : 0.012;  // of full scale (1 10-bit code = 0.001)
    for (int c = 0; c < 3; ++c) EXPECT_LT(mean_error[static_cast<std::size_t>(c)], limit) << "q" << quality << " c" << c;
  }
}

// ---- the container, read with the test's own ISOBMFF walker -----------------------------------
struct Box {
  std::string type;
  std::size_t payload = 0, end = 0;
};
std::vector<Box> boxes(const Bytes& b, std::size_t begin, std::size_t end) {
  std::vector<Box> out;
  for (std::size_t at = begin; at + 8 <= end;) {
    const auto size = static_cast<std::size_t>(stilltest::be(b, at, 4));
    if (size < 8 || at + size > end) throw std::runtime_error("bad box size");
    out.push_back({std::string(b.begin() + static_cast<long>(at + 4), b.begin() + static_cast<long>(at + 8)), at + 8,
                   at + size});
    at += size;
  }
  return out;
}
Box child(const Bytes& b, const Box& parent, const std::string& type, std::size_t skip = 0) {
  for (const Box& c : boxes(b, parent.payload + skip, parent.end))
    if (c.type == type) return c;
  throw std::runtime_error("no " + type + " box");
}

TEST(AvifBoxes, ClliAndMdcvAreThePrimaryItemsProperties) {
  EncodedFrame f = stilltest::rendition(small_scene(), Mode::hdr10);
  f.content_light = {987.2, 123.0};  // -> 988 and 123 cd/m2 (rounded up, CTA-861.3 units)
  const auto avif = encode_avif(f);
  ASSERT_TRUE(avif.ok());
  const Bytes& b = *avif;
  const Box file{"", 0, b.size()};
  const Box meta = child(b, file, "meta");
  const Box iprp = child(b, meta, "iprp", 4);
  const Box ipco = child(b, iprp, "ipco");
  const auto props = boxes(b, ipco.payload, ipco.end);
  std::map<std::string, std::size_t> index;  // 1-based, as ipma counts
  for (std::size_t i = 0; i < props.size(); ++i) index[props[i].type] = i + 1;
  ASSERT_TRUE(index.count("clli") && index.count("mdcv") && index.count("colr"));
  const Box clli = props[index["clli"] - 1], mdcv = props[index["mdcv"] - 1];
  EXPECT_EQ(Bytes(b.begin() + static_cast<long>(clli.payload), b.begin() + static_cast<long>(clli.end)),
            (Bytes{0x03, 0xDC, 0x00, 0x7B}));
  // ST 2086 for P3-D65, 1000 / 0.005 cd/m2, in HEVC order G, B, R, then white (0.00002 units),
  // then max and min luminance (0.0001 cd/m2 units).
  EXPECT_EQ(Bytes(b.begin() + static_cast<long>(mdcv.payload), b.begin() + static_cast<long>(mdcv.end)),
            (Bytes{0x33, 0xC2, 0x86, 0xC4, 0x1D, 0x4C, 0x0B, 0xB8, 0x84, 0xD0, 0x3E, 0x80, 0x3D, 0x13, 0x40, 0x42,
                   0x00, 0x98, 0x96, 0x80, 0x00, 0x00, 0x00, 0x32}));
  // ipma (version 0, 7-bit indices): the primary item (pitm) lists both, not essential.
  const Box pitm = child(b, meta, "pitm", 4);
  const auto item = stilltest::be(b, pitm.payload + 4, 2);
  const Box ipma = child(b, iprp, "ipma");
  ASSERT_EQ(b[ipma.payload], 0);
  ASSERT_EQ(stilltest::be(b, ipma.payload + 1, 3) & 1, 0u);
  std::size_t at = ipma.payload + 8;
  std::set<std::size_t> associated;
  for (auto e = stilltest::be(b, ipma.payload + 4, 4); e > 0; --e) {
    const auto id = stilltest::be(b, at, 2);
    const std::size_t n = b[at + 2];
    for (std::size_t k = 0; k < n; ++k)
      if (id == item) associated.insert(b[at + 3 + k]);
    at += 3 + n;
  }
  EXPECT_TRUE(associated.count(index["clli"]));  // essential bit (0x80) clear
  EXPECT_TRUE(associated.count(index["mdcv"]));
}

TEST(AvifBoxes, HeifInfoReadsTheContentLightAndMastering) {
  HDRD_REQUIRE_TOOL("heif-info", "libheif-examples");
  EncodedFrame f = stilltest::rendition(small_scene(), Mode::hlg);
  f.content_light = {640.5, 80.25};
  f.mastering = {color::kRec2020, 1000.0, 0.0001};
  TempDir tmp;
  ASSERT_TRUE(write_avif(tmp / "f.avif", f).ok());
  const auto info = testing::run_command("heif-info " + (tmp / "f.avif").string());
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(line_with(info.out, "max content light level").find(": 641"), std::string::npos) << info.out;
  EXPECT_NE(line_with(info.out, "max pic average light level").find(": 81"), std::string::npos) << info.out;
  // heif-info prints the primaries in file order: G, B, R (Rec.2020).
  EXPECT_NE(line_with(info.out, "display_primaries").find("(0.17;0.797), (0.131;0.046), (0.708;0.292)"), std::string::npos)
      << info.out;
  EXPECT_NE(line_with(info.out, "max display mastering luminance").find(": 1000"), std::string::npos) << info.out;
  EXPECT_NE(line_with(info.out, "min display mastering luminance").find(": 0.0001"), std::string::npos) << info.out;
}

TEST(AvifBoxes, SdrHasNeitherClliNorMdcv) {
  const auto avif = encode_avif(stilltest::rendition(small_scene(), Mode::sdr));
  ASSERT_TRUE(avif.ok());
  const std::string s(avif->begin(), avif->end());
  EXPECT_EQ(s.find("clli"), std::string::npos);
  EXPECT_EQ(s.find("mdcv"), std::string::npos);
}

TEST(AvifErrors, NameWhatIsWrong) {
  const EncodedFrame hdr = stilltest::rendition(small_scene(), Mode::hdr10);
  const auto expect_error = [&](const EncodedFrame& f, const AvifOptions& o, const std::string& code,
                                const std::string& field) {
    const auto r = encode_avif(f, o);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, code) << r.error().message;
    EXPECT_EQ(r.error().field, field) << r.error().message;
    EXPECT_FALSE(r.error().message.empty());
  };
  AvifOptions o;
  o.lossless = true;
  o.matrix = AvifMatrix::ycbcr;
  expect_error(hdr, o, "avif.options", "avif.matrix");
  o = {};
  o.matrix = AvifMatrix::rgb;
  o.chroma = ChromaSubsampling::yuv420;
  expect_error(hdr, o, "avif.options", "avif.chroma");
  o = {};
  o.bits = 9;
  expect_error(hdr, o, "avif.options", "avif.bits");
  o = {};
  o.lossless = true;
  o.bits = 12;
  expect_error(hdr, o, "avif.options", "avif.bits");
  o = {};
  o.lossless = true;
  o.range = Range::narrow;
  expect_error(hdr, o, "avif.options", "avif.range");
  o = {};
  o.quality = 101;
  expect_error(hdr, o, "avif.options", "avif.quality");
  o = {};
  o.speed = 10;
  expect_error(hdr, o, "avif.options", "avif.speed");
  EncodedFrame scrgb = stilltest::rendition(small_scene(), Mode::scrgb);
  expect_error(scrgb, {}, "avif.unsupported", "format");
  EncodedFrame broken = hdr;
  broken.data.resize(10);
  expect_error(broken, {}, "frame.invalid", "");
}

}  // namespace
}  // namespace hdrd::io

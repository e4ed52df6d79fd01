// The PNG writer's multi-threaded zlib stream: for every mode, level and thread count the
// file decodes to exactly the frame's samples (REFERENCE.md §1.7: round(E' 65535) from
// signal16, the 10-bit code x 64 for narrow range, the 8-bit codes as they are), through
// zlib's inflate (which checks the combined Adler-32) with the test's own filter decoder,
// through libpng, and through pngcheck, ffmpeg and ImageMagick when installed. The frames
// are real encodes of a fixture, large enough for several segments per file.
#include <cstdio>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

using Bytes = std::vector<std::uint8_t>;

struct ModeCase {
  std::string name;
  Mode mode;
  int bits;
  Range range = Range::full;
  SdrCurve curve = SdrCurve::srgb;
  bool png_samples = true;  // false: the writer widens the 10-bit codes itself
};

void PrintTo(const ModeCase& k, std::ostream* os) { *os << k.name; }  // failure messages name the case

const std::vector<ModeCase>& mode_cases() {
  static const std::vector<ModeCase> cases{
      {"hdr10", Mode::hdr10, 10},
      {"hdr10_narrow", Mode::hdr10, 10, Range::narrow},
      {"hdr10_codes_only", Mode::hdr10, 10, Range::full, SdrCurve::srgb, false},
      {"hlg", Mode::hlg, 10},
      {"sdr_8bit_srgb", Mode::sdr, 8},
      {"sdr_8bit_gamma22", Mode::sdr, 8, Range::full, SdrCurve::gamma22},
      {"sdr_10bit", Mode::sdr, 10},
      {"sdr_bt1886_8bit", Mode::sdr_bt1886, 8},
      {"sdr_bt1886_10bit_narrow", Mode::sdr_bt1886, 10, Range::narrow},
  };
  return cases;
}

// Desk (644 x 874): 16-bit lines of 3865 bytes, 4 segments of ~1 MiB per file (8-bit: 2).
constexpr const char* kSource = "fixtures/exr/Desk.exr";
const ExrImage& source() {
  static const ExrImage exr = [] {
    const auto path = testing::fixture(kSource);
    if (!path) return ExrImage{};
    return read_exr(*path).value();
  }();
  return exr;
}

EncodedFrame frame_for(const ModeCase& k) {
  const ExrImage& exr = source();
  EncodeSettings s;
  s.target = default_target(k.mode);
  s.target.bits = k.bits;
  s.target.range = k.range;
  s.target.sdr_curve = k.curve;
  s.png_samples = k.png_samples;
  SceneInput in;
  in.image = &exr.image;
  in.to_working = exr.to_working();
  return encode_frame(in, s).value();
}

// The samples the PNG must hold, worked out from the frame's buffer by the rules above.
std::vector<std::uint16_t> expected_samples(const EncodedFrame& f) {
  std::vector<std::uint16_t> out;
  out.reserve(static_cast<std::size_t>(f.width) * f.height * 3);
  const bool eight = f.drm_fourcc == kDrmFormatXrgb8888, narrow = f.target.range == Range::narrow;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const std::uint8_t* p = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + x * 4;
      const std::uint32_t word = p[0] | (p[1] << 8) | (p[2] << 16) | (std::uint32_t(p[3]) << 24);
      for (int c = 0; c < 3; ++c) {
        const std::size_t i = (static_cast<std::size_t>(y) * f.width + x) * 3 + c;
        const std::uint32_t code = (word >> (10 * c)) & 0x3ff;
        if (eight) out.push_back(p[2 - c]);  // XRGB8888 bytes B, G, R, X
        else if (narrow) out.push_back(static_cast<std::uint16_t>(code << 6));
        else if (!f.signal16.empty()) out.push_back(f.signal16[i]);
        else out.push_back(static_cast<std::uint16_t>(std::lround(code / 1023.0 * 65535)));
      }
    }
  return out;
}

int idat_count(const Bytes& png) {
  int n = 0;
  for (const auto& c : pngtest::chunks_of(png)) n += c.type == "IDAT";
  return n;
}

class EveryMode : public ::testing::TestWithParam<ModeCase> {};

TEST_P(EveryMode, DecodesToTheFrameSamplesAtAnyThreadCount) {
  HDRD_REQUIRE_FIXTURE(exr_path, kSource);
  const EncodedFrame f = frame_for(GetParam());
  const auto want = expected_samples(f);
  const auto one = encode_png(f, {.level = kDefaultPngLevel, .threads = 1});
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_GE(idat_count(*one), 2) << "the frame should span several segments";
  for (const auto& c : pngtest::chunks_of(*one)) EXPECT_TRUE(c.crc_ok) << c.type;
  EXPECT_EQ(pngtest::decode_rgb(*one).samples, want);
  const auto info = read_png_info_memory(*one);
  ASSERT_TRUE(info.ok()) << info.error().message;
  EXPECT_EQ(info->samples, want);
  for (int threads : {2, 3, 7}) {  // the file depends on the image only
    const auto many = encode_png(f, {.level = kDefaultPngLevel, .threads = threads});
    ASSERT_TRUE(many.ok());
    EXPECT_EQ(*many, *one) << threads << " threads";
  }
}

INSTANTIATE_TEST_SUITE_P(PngStream, EveryMode, ::testing::ValuesIn(mode_cases()),
                         [](const auto& info) { return info.param.name; });

class EveryLevel : public ::testing::TestWithParam<int> {};

TEST_P(EveryLevel, DecodesExactlyAndSmallerLevelsAreNotLarger) {
  HDRD_REQUIRE_FIXTURE(exr_path, kSource);
  static const EncodedFrame f = frame_for(mode_cases()[0]);
  static const auto want = expected_samples(f);
  const int level = GetParam();
  const auto png = encode_png(f, {.level = level});
  ASSERT_TRUE(png.ok()) << png.error().message;
  EXPECT_EQ(pngtest::decode_rgb(*png).samples, want);
  EXPECT_EQ(read_png_info_memory(*png)->samples, want);
  const std::size_t raw = static_cast<std::size_t>(f.width) * f.height * 6;
  if (level == 0) EXPECT_GT(png->size(), raw);        // stored: the filtered bytes plus block headers
  else EXPECT_LT(png->size(), raw * 95 / 100);        // compressed
  if (level >= 4) {  // the small-file levels: smaller than the fast default (per-line filters, two deflaters)
    const auto fast = encode_png(f, {.level = kDefaultPngLevel});
    EXPECT_LT(png->size(), fast->size()) << "level " << level;
  }
}

// Synthetic content (flat bands, ramps, a fine checker: what patterns and UIs look like)
// is where zlib's match search pays: the small-file levels must be much smaller there.
TEST(PngStream, SmallFileLevelsPayOnSyntheticContent) {
  EncodedFrame f;
  f.target = default_target(Mode::hdr10);
  f.width = 1024;
  f.height = 600;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = 4096;
  f.data.resize(f.stride_bytes * f.height);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const std::uint32_t band = static_cast<std::uint32_t>(y / 75) * 128, ramp = static_cast<std::uint32_t>(x);
      const std::uint32_t check = ((x / 2 + y / 2) % 2) * 900;
      const std::uint32_t word = (y < 300 ? band : ramp) | ((y < 300 ? band : check) << 10) | (ramp << 20);
      std::memcpy(f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + x * 4, &word, 4);
    }
  const auto fast = encode_png(f, {.level = kDefaultPngLevel}), small = encode_png(f, {.level = 6});
  ASSERT_TRUE(fast.ok() && small.ok());
  EXPECT_EQ(pngtest::decode_rgb(*small).samples, expected_samples(f));
  EXPECT_LT(small->size(), fast->size() * 8 / 10) << fast->size() << " -> " << small->size();
}

INSTANTIATE_TEST_SUITE_P(PngStream, EveryLevel, ::testing::Range(kMinPngLevel, kMaxPngLevel + 1),
                         [](const auto& info) { return "level" + std::to_string(info.param); });

TEST(PngStream, OptionsOutOfRangeAreErrorsNamingTheField) {
  EncodedFrame f;
  f.target = default_target(Mode::sdr);
  f.width = f.height = 1;
  f.drm_fourcc = kDrmFormatXrgb8888;
  f.stride_bytes = 4;
  f.data.assign(4, 0);
  for (int level : {-1, 10}) {
    const auto r = encode_png(f, {.level = level});
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, "png.level");
    EXPECT_EQ(r.error().field, "png_level");
    EXPECT_NE(r.error().message.find(std::to_string(level)), std::string::npos) << r.error().message;
  }
  EXPECT_EQ(encode_png(f, {.threads = -2}).error().code, "png.threads");
  EXPECT_TRUE(encode_png(f, {.level = 9, .threads = 64}).ok());  // more threads than segments
}

// Third-party readers: pngcheck (chunk CRCs, the zlib stream and its Adler-32), ffmpeg's
// PNG decoder and ImageMagick (libpng), each decoding to the expected samples.
std::string tool(const std::string& name) {
  const auto r = testing::run_command("command -v " + name + " 2>/dev/null");
  std::string path = r.exit_code == 0 ? r.out : "";
  while (!path.empty() && (path.back() == '\n' || path.back() == ' ')) path.pop_back();
  return path;
}

std::string without_hdr_chunks(const std::string& png) {
  std::string out = png.substr(0, 8);
  for (std::size_t pos = 8; pos + 12 <= png.size();) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(png.data() + pos);
    const std::size_t n = pngtest::be32(p);
    const std::string type = png.substr(pos + 4, 4);
    if (type != "cICP" && type != "mDCV" && type != "cLLI") out += png.substr(pos, 12 + n);
    pos += 12 + n;
  }
  return out;
}

Bytes be_bytes(const std::vector<std::uint16_t>& samples, bool sixteen) {
  Bytes b;
  for (std::uint16_t s : samples) {
    if (sixteen) b.push_back(static_cast<std::uint8_t>(s >> 8));
    b.push_back(static_cast<std::uint8_t>(s));
  }
  return b;
}

TEST(PngStream, ThirdPartyReadersDecodeEveryMode) {
  HDRD_REQUIRE_FIXTURE(exr_path, kSource);
  const std::string pngcheck = tool("pngcheck"), ffmpeg = tool("ffmpeg");
  // Debian's ImageMagick 6 binary by name: /usr/local/bin/convert may be a stand-in.
  const std::string magick = tool("convert-im6.q16").empty() ? tool("magick") : tool("convert-im6.q16");
  if (pngcheck.empty() && ffmpeg.empty() && magick.empty())
    GTEST_SKIP() << "none of pngcheck, ffmpeg, ImageMagick installed (apt-get install pngcheck ffmpeg imagemagick)";
  testing::TempDir tmp;
  for (const ModeCase& k : mode_cases()) {
    // One case per distinct writer path: signal16, narrow codes, 8-bit sRGB chunks, 8-bit gamma chunks.
    if (k.name != "hdr10" && k.name != "hdr10_narrow" && k.name != "sdr_8bit_srgb" && k.name != "sdr_bt1886_8bit")
      continue;
    const EncodedFrame f = frame_for(k);
    const bool sixteen = f.drm_fourcc != kDrmFormatXrgb8888;
    const Bytes want = be_bytes(expected_samples(f), sixteen);
    const auto path = tmp / (k.name + ".png");
    ASSERT_TRUE(write_png(path, f).ok());
    if (!pngcheck.empty()) {
      // pngcheck 3.0.3 stops at chunks registered after it (cICP, mDCV, cLLI: "illegal
      // unknown, public chunk"), so it checks a copy without them; they are ancillary.
      const auto stripped = tmp / (k.name + ".pngcheck.png");
      std::ofstream(stripped, std::ios::binary) << without_hdr_chunks(testing::read_file(path));
      const auto r = testing::run_command(pngcheck + " -q '" + stripped.string() + "'");
      EXPECT_EQ(r.exit_code, 0) << k.name << ": " << r.out << r.err;
    }
    const auto decoded_by = [&](const std::string& command) {
      const auto raw = tmp / (k.name + ".rgb");
      const auto r = testing::run_command(command + " 2>&1");
      EXPECT_EQ(r.exit_code, 0) << k.name << ": " << r.out;
      const std::string got = testing::read_file(raw);
      std::filesystem::remove(raw);
      return Bytes(got.begin(), got.end());
    };
    const std::string raw = (tmp / (k.name + ".rgb")).string();
    if (!ffmpeg.empty()) {
      EXPECT_EQ(decoded_by(ffmpeg + " -v error -y -i '" + path.string() + "' -f rawvideo -pix_fmt " +
                           (sixteen ? "rgb48be" : "rgb24") + " '" + raw + "'"),
                want)
          << "ffmpeg, " << k.name;
    }
    if (!magick.empty()) {
      EXPECT_EQ(decoded_by(magick + " '" + path.string() + "' -depth " + (sixteen ? "16" : "8") + " -endian MSB 'rgb:" +
                           raw + "'"),
                want)
          << "ImageMagick, " << k.name;
    }
  }
}

}  // namespace
}  // namespace hdrd::io

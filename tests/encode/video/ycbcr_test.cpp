// R'G'B' -> Y'CbCr 4:2:0 (encode/video/ycbcr.hpp) against the BT.2020 and BT.709
// equations with their published constants, evaluated in this test per sample, for every
// mode, depth and both ranges on each side.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "encode/video/ycbcr.hpp"
#include "tests/encode/video/video_testing.hpp"

using namespace hdrd;
using namespace hdrd::video;
using namespace hdrd::video::testing;

namespace {

struct Case {
  Mode mode;
  int bits;
  Range in, out;
};
void PrintTo(const Case& c, std::ostream* os) {
  *os << to_string(c.mode) << " " << c.bits << "-bit " << to_string(c.in) << " to " << to_string(c.out);
}

std::string case_name(const ::testing::TestParamInfo<Case>& i) {
  std::string m(to_string(i.param.mode));
  for (auto& c : m)
    if (c == '-') c = '_';
  return m + "_" + std::to_string(i.param.bits) + "bit_" + std::string(to_string(i.param.in)) + "_to_" +
         std::string(to_string(i.param.out));
}

struct Planes {
  int w, h, bits;
  std::vector<std::uint16_t> y, cb, cr;  // widened
  std::vector<std::uint8_t> raw_y, raw_cb, raw_cr;
  Planes(int w_, int h_, int bits_) : w(w_), h(h_), bits(bits_) {
    const std::size_t bps = bits == 10 ? 2 : 1;
    raw_y.assign(static_cast<std::size_t>(w) * h * bps + 64, 0xAB);
    raw_cb.assign(static_cast<std::size_t>(w / 2) * (h / 2) * bps + 64, 0xAB);
    raw_cr = raw_cb;
  }
  Planes420 view() {
    const std::ptrdiff_t bps = bits == 10 ? 2 : 1;
    return {{raw_y.data(), w * bps}, {raw_cb.data(), w / 2 * bps}, {raw_cr.data(), w / 2 * bps}};
  }
  int at(const std::vector<std::uint8_t>& p, int stride_samples, int x, int y) const {
    const std::size_t i = static_cast<std::size_t>(y) * stride_samples + x;
    if (bits == 8) return p[i];
    return p[2 * i] | (p[2 * i + 1] << 8);
  }
  int Y(int x, int y) const { return at(raw_y, w, x, y); }
  int Cb(int x, int y) const { return at(raw_cb, w / 2, x, y); }
  int Cr(int x, int y) const { return at(raw_cr, w / 2, x, y); }
};

// The expected code: round(exact), clipped. The kernel evaluates in single precision
// (within 3e-4 of a code), so within 1e-3 of a rounding tie either neighbour is right.
void expect_code(int got, double exact, int max_code, const char* what, int x, int y, int& mismatches) {
  const double clipped = std::clamp(exact, 0.0, static_cast<double>(max_code));
  const int want = static_cast<int>(std::floor(clipped + 0.5));
  const bool tie = std::abs(clipped - std::floor(clipped) - 0.5) < 1e-3;
  if (got == want || (tie && std::abs(got - want) <= 1)) return;
  if (++mismatches <= 5) ADD_FAILURE() << what << " at (" << x << "," << y << "): got " << got << ", equations give " << exact;
}

class Ycbcr : public ::testing::TestWithParam<Case> {};

TEST_P(Ycbcr, MatchesTheEquationsAtEverySample) {
  const Case c = GetParam();
  const int w = 38, h = 14;  // even, not a multiple of 4, so the last chroma column has no right neighbour beyond x+1
  const EncodedFrame f = random_frame(c.mode, c.in, c.bits, w, h, 17);
  auto fmt = ycbcr_format_for(f, c.out);
  ASSERT_TRUE(fmt.ok()) << fmt.error().message;
  Planes p(w, h, c.bits);
  ASSERT_TRUE(rgb_to_ycbcr420(f, *fmt, p.view()).ok());
  const bool rec2020 = c.mode == Mode::hdr10 || c.mode == Mode::hlg;
  const int max_code = (1 << c.bits) - 1;
  int mismatches = 0;
  auto e = [&](int x, int y) {
    const Codes k = codes_at(f, std::clamp(x, 0, w - 1), y);
    return std::array<double, 3>{signal_of(k.r, c.bits, c.in), signal_of(k.g, c.bits, c.in), signal_of(k.b, c.bits, c.in)};
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto s = e(x, y);
      expect_code(p.Y(x, y), ycbcr_exact(s[0], s[1], s[2], rec2020, c.bits, c.out).y, max_code, "Y", x, y, mismatches);
    }
  // Chroma sited left (H.273 type 0): [1 2 1]/4 across columns 2i-1..2i+1, mean of rows 2j, 2j+1.
  for (int j = 0; j < h / 2; ++j)
    for (int i = 0; i < w / 2; ++i) {
      std::array<double, 3> m{};
      for (int dy = 0; dy < 2; ++dy)
        for (auto [dx, wgt] : {std::pair{-1, 0.25}, std::pair{0, 0.5}, std::pair{1, 0.25}}) {
          const auto s = e(2 * i + dx, 2 * j + dy);
          for (int k = 0; k < 3; ++k) m[static_cast<std::size_t>(k)] += 0.5 * wgt * s[static_cast<std::size_t>(k)];
        }
      const YcbcrExact want = ycbcr_exact(m[0], m[1], m[2], rec2020, c.bits, c.out);
      expect_code(p.Cb(i, j), want.cb, max_code, "Cb", i, j, mismatches);
      expect_code(p.Cr(i, j), want.cr, max_code, "Cr", i, j, mismatches);
    }
  EXPECT_EQ(mismatches, 0);
}

INSTANTIATE_TEST_SUITE_P(
    AllForms, Ycbcr,
    ::testing::Values(Case{Mode::hdr10, 10, Range::full, Range::narrow}, Case{Mode::hdr10, 10, Range::full, Range::full},
                      Case{Mode::hdr10, 10, Range::narrow, Range::narrow}, Case{Mode::hdr10, 10, Range::narrow, Range::full},
                      Case{Mode::hlg, 10, Range::full, Range::narrow}, Case{Mode::sdr, 10, Range::full, Range::narrow},
                      Case{Mode::sdr, 8, Range::full, Range::narrow}, Case{Mode::sdr, 8, Range::narrow, Range::full},
                      Case{Mode::sdr_bt1886, 8, Range::narrow, Range::narrow}),
    case_name);

TEST(Ycbcr, PublishedLevels) {
  // BT.2100 Table 9 / BT.2020: 10-bit narrow black 64, white 940, neutral chroma 512; full
  // range white 1023, chroma 512; 8-bit narrow 16 / 235 / 128.
  auto convert = [](Mode mode, int bits, Range out, int code) {
    const EncodedFrame f = frame_of_codes(mode, Range::full, bits, 4, 2, [&](int, int) { return std::array<int, 3>{code, code, code}; });
    Planes p(4, 2, bits);
    EXPECT_TRUE(rgb_to_ycbcr420(f, *ycbcr_format_for(f, out), p.view()).ok());
    return std::array<int, 3>{p.Y(1, 1), p.Cb(1, 0), p.Cr(1, 0)};
  };
  EXPECT_EQ(convert(Mode::hdr10, 10, Range::narrow, 1023), (std::array<int, 3>{940, 512, 512}));
  EXPECT_EQ(convert(Mode::hdr10, 10, Range::narrow, 0), (std::array<int, 3>{64, 512, 512}));
  EXPECT_EQ(convert(Mode::hdr10, 10, Range::full, 1023), (std::array<int, 3>{1023, 512, 512}));
  EXPECT_EQ(convert(Mode::sdr, 8, Range::narrow, 255), (std::array<int, 3>{235, 128, 128}));
  EXPECT_EQ(convert(Mode::sdr, 8, Range::narrow, 0), (std::array<int, 3>{16, 128, 128}));
  // PQ 203 cd/m2 grey (full code 594) in narrow range: round((219 * 594/1023 + 16) * 4) = 573,
  // REFERENCE.md §2's narrow code for 203 cd/m2.
  EXPECT_EQ(convert(Mode::hdr10, 10, Range::narrow, 594)[0], 573);
}

TEST(Ycbcr, BadInputNamesWhatIsWrong) {
  const EncodedFrame odd = random_frame(Mode::hdr10, Range::full, 10, 5, 4, 1);
  Planes p(6, 4, 10);
  auto r = rgb_to_ycbcr420(odd, *ycbcr_format_for(odd, Range::narrow), p.view());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "video.size");
  EncodedFrame scrgb = random_frame(Mode::hdr10, Range::full, 10, 4, 4, 1);
  scrgb.target.mode = Mode::scrgb;
  EXPECT_EQ(ycbcr_format_for(scrgb, Range::narrow).error().code, "video.mode");
  EncodedFrame truncated = random_frame(Mode::hdr10, Range::full, 10, 4, 4, 1);
  truncated.data.resize(10);
  EXPECT_FALSE(rgb_to_ycbcr420(truncated, YcbcrFormat{}, p.view()).ok());
  const EncodedFrame ok = random_frame(Mode::hdr10, Range::full, 10, 4, 4, 1);
  EXPECT_EQ(rgb_to_ycbcr420(ok, YcbcrFormat{8, Range::narrow, color::kRec2020Luma}, p.view()).error().code, "video.format");
}

}  // namespace

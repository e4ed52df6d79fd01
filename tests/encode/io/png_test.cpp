// PNG dumps: chunk bytes against values worked out by hand from the PNG 3rd edition
// (cICP §11.3.2.6, mDCV §11.3.2.7, cLLI §11.3.2.8), H.273 code points and REFERENCE.md §6;
// CRCs and samples checked with the test's own chunk reader and inflate decoder, and by
// decoding through libpng (read_png_info).
#include <cmath>

#include <gtest/gtest.h>

#include "encode/io/io.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

using Bytes = std::vector<std::uint8_t>;

// A signal value per pixel and channel, in [0, 1].
double signal_at(int x, int y, int c) { return ((x * 7 + y * 13 + c * 5) % 101) / 100.0; }

void put_le32(Bytes& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// XBGR2101010 frame (R in bits 0-9) with padded stride, codes round(E' 1023), signal16
// round(E' 65535), as REFERENCE.md §1.7 defines them.
EncodedFrame ten_bit_frame(Mode mode, int w, int h, std::size_t pad = 12) {
  EncodedFrame f;
  f.target = default_target(mode);
  f.target.bits = 10;
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = static_cast<std::size_t>(w) * 4 + pad;
  f.data.assign(f.stride_bytes * h, 0xee);  // padding holds junk that must not leak
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint32_t word = 0;
      for (int c = 0; c < 3; ++c) {
        word |= static_cast<std::uint32_t>(std::lround(signal_at(x, y, c) * 1023)) << (10 * c);
        f.signal16.push_back(static_cast<std::uint16_t>(std::lround(signal_at(x, y, c) * 65535)));
      }
      put_le32(f.data, y * f.stride_bytes + x * 4, word);
    }
  f.mastering = MasteringDisplay{};  // P3-D65, 1000 / 0.005 cd/m2
  f.content_light = {1000.0, 123.45};
  return f;
}

// XRGB8888 frame: bytes B, G, R, X.
EncodedFrame eight_bit_frame(int w, int h) {
  EncodedFrame f;
  f.target = default_target(Mode::sdr);
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXrgb8888;
  f.stride_bytes = static_cast<std::size_t>(w) * 4 + 8;
  f.data.assign(f.stride_bytes * h, 0x77);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = &f.data[y * f.stride_bytes + x * 4];
      p[0] = static_cast<std::uint8_t>(10 + x);       // B
      p[1] = static_cast<std::uint8_t>(100 + y);      // G
      p[2] = static_cast<std::uint8_t>(200 + x + y);  // R
      p[3] = 0xff;                                    // X
    }
  return f;
}

std::vector<std::string> types(const std::vector<pngtest::Chunk>& cs) {
  std::vector<std::string> t;
  for (const auto& c : cs)
    if (t.empty() || t.back() != c.type) t.push_back(c.type);  // IDATs collapse to one
  return t;
}

const pngtest::Chunk* find(const std::vector<pngtest::Chunk>& cs, const std::string& type) {
  for (const auto& c : cs)
    if (c.type == type) return &c;
  return nullptr;
}

TEST(PngWrite, Hdr10ChunksBytesOrderAndCrcs) {
  const EncodedFrame f = ten_bit_frame(Mode::hdr10, 5, 3);
  const auto png = encode_png(f);
  ASSERT_TRUE(png.ok()) << png.error().message;
  const auto cs = pngtest::chunks_of(*png);
  EXPECT_EQ(types(cs), (std::vector<std::string>{"IHDR", "cICP", "mDCV", "cLLI", "IDAT", "IEND"}));
  for (const auto& c : cs) EXPECT_TRUE(c.crc_ok) << c.type;
  // IHDR: 5 x 3, 16-bit, colour type 2 (RGB), no interlace.
  EXPECT_EQ(find(cs, "IHDR")->data, (Bytes{0, 0, 0, 5, 0, 0, 0, 3, 16, 2, 0, 0, 0}));
  // cICP: BT.2020 primaries (9), PQ (16), identity matrix (0), full range (1).
  EXPECT_EQ(find(cs, "cICP")->data, (Bytes{0x09, 0x10, 0x00, 0x01}));
  // platform-debian12.md §6 recorded this chunk's CRC from an independent Python check.
  const std::size_t at = 8 + 25;  // signature + IHDR chunk
  EXPECT_EQ(pngtest::be32(&(*png)[at + 12]), 0x4D2323FEu);
  // mDCV for P3-D65, 1000 / 0.005 cd/m2: x, y / 0.00002 and cd/m2 / 0.0001.
  EXPECT_EQ(find(cs, "mDCV")->data, (Bytes{0x84, 0xD0, 0x3E, 0x80,     // R 0.680 -> 34000, 0.320 -> 16000
                                           0x33, 0xC2, 0x86, 0xC4,     // G 0.265 -> 13250, 0.690 -> 34500
                                           0x1D, 0x4C, 0x0B, 0xB8,     // B 0.150 -> 7500, 0.060 -> 3000
                                           0x3D, 0x13, 0x40, 0x42,     // W 0.3127 -> 15635, 0.3290 -> 16450
                                           0x00, 0x98, 0x96, 0x80,     // 1000 cd/m2 -> 10 000 000
                                           0x00, 0x00, 0x00, 0x32}));  // 0.005 cd/m2 -> 50
  // cLLI: the whole cd/m2 every container carries (encode/frame.hpp), in 0.0001 cd/m2:
  // MaxCLL 1000 -> 10 000 000; MaxFALL 123.45 rounds up to 124 -> 1 240 000 (0x12EBC0).
  EXPECT_EQ(find(cs, "cLLI")->data, (Bytes{0x00, 0x98, 0x96, 0x80, 0x00, 0x12, 0xEB, 0xC0}));
}

TEST(PngWrite, Hdr10SamplesAreRoundSignalTimes65535) {
  const EncodedFrame f = ten_bit_frame(Mode::hdr10, 7, 4);
  const auto png = encode_png(f);
  ASSERT_TRUE(png.ok());
  const auto d = pngtest::decode_rgb(*png);
  ASSERT_EQ(d.bit_depth, 16);
  ASSERT_EQ(d.samples.size(), 7u * 4 * 3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 7; ++x)
      for (int c = 0; c < 3; ++c)  // from the signal, not code << 6 (e.g. 0.37 -> 24248, not 24279)
        ASSERT_EQ(d.samples[(y * 7 + x) * 3 + c], std::lround(signal_at(x, y, c) * 65535)) << x << "," << y;
}

TEST(PngWrite, ReadPngInfoDecodesTheSameThroughLibpng) {
  const EncodedFrame f = ten_bit_frame(Mode::hlg, 6, 5);
  const auto png = encode_png(f);
  ASSERT_TRUE(png.ok());
  const auto info = read_png_info_memory(*png);
  ASSERT_TRUE(info.ok()) << info.error().message;
  EXPECT_EQ(info->width, 6);
  EXPECT_EQ(info->bit_depth, 16);
  EXPECT_EQ(info->color_type, 2);
  EXPECT_EQ(info->channels, 3);
  ASSERT_TRUE(info->cicp.has_value());
  EXPECT_EQ(*info->cicp, (std::array<std::uint8_t, 4>{9, 18, 0, 1}));  // HLG = 18
  ASSERT_TRUE(info->mdcv && info->clli);
  EXPECT_EQ(info->mdcv->size(), 24u);
  EXPECT_EQ(info->clli->size(), 8u);
  EXPECT_EQ(info->samples, f.signal16);
}

TEST(PngWrite, NarrowRangeClearsTheFlagAndCodesSamplesNarrow) {
  EncodedFrame f = ten_bit_frame(Mode::hdr10, 4, 2, 0);
  f.target.range = Range::narrow;
  std::vector<long> codes;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      std::uint32_t word = 0;
      for (int c = 0; c < 3; ++c) {  // BT.2100 Table 9, 10-bit narrow: round((219 E' + 16) 4)
        codes.push_back(std::lround((219 * signal_at(x, y, c) + 16) * 4));
        word |= static_cast<std::uint32_t>(codes.back()) << (10 * c);
      }
      put_le32(f.data, y * f.stride_bytes + x * 4, word);
    }
  const auto png = encode_png(f);
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(find(pngtest::chunks_of(*png), "cICP")->data, (Bytes{9, 16, 0, 0}));
  const auto d = pngtest::decode_rgb(*png);
  ASSERT_EQ(d.samples.size(), codes.size());
  for (std::size_t i = 0; i < codes.size(); ++i) {
    // The same formula at 16 bits, round((219 E' + 16) 2^8), is the 10-bit code x 64:
    // black 64 -> 4096, white 940 -> 60160.
    EXPECT_EQ(d.samples[i], codes[i] * 64) << i;
    EXPECT_NEAR(d.samples[i], (219 * (f.signal16[i] / 65535.0) + 16) * 256, 0.5 * 64 + 1) << i;
  }
}

TEST(PngWrite, WithoutSignal16TheCodesAreWidenedExactly) {
  EncodedFrame f = ten_bit_frame(Mode::hdr10, 3, 2, 0);
  f.signal16.clear();
  const auto d = pngtest::decode_rgb(*encode_png(f));
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) {
        const long code = std::lround(signal_at(x, y, c) * 1023);
        EXPECT_EQ(d.samples[(y * 3 + x) * 3 + c], std::lround(code / 1023.0 * 65535));
      }
}

TEST(PngWrite, TenBitSdrHasCicpButNoHdrChunks) {
  struct Case { Mode mode; SdrCurve curve; std::uint8_t transfer; };
  // H.273 Table 3: 13 = IEC 61966-2-1 sRGB, 4 = assumed display gamma 2.2, 1 = BT.709 (BT.1886 display).
  for (const Case& k : {Case{Mode::sdr, SdrCurve::srgb, 13}, Case{Mode::sdr, SdrCurve::gamma22, 4},
                        Case{Mode::sdr_bt1886, SdrCurve::srgb, 1}}) {
    EncodedFrame f = ten_bit_frame(k.mode, 4, 3);
    f.target.sdr_curve = k.curve;
    const auto png = encode_png(f);
    ASSERT_TRUE(png.ok()) << png.error().message;
    const auto cs = pngtest::chunks_of(*png);
    EXPECT_EQ(find(cs, "cICP")->data, (Bytes{1, k.transfer, 0, 1}));
    EXPECT_EQ(find(cs, "mDCV"), nullptr);
    EXPECT_EQ(find(cs, "cLLI"), nullptr);
    EXPECT_EQ(find(cs, "IHDR")->data[8], 16);
  }
}

// The chunk order docs/dump-format.md §3 states, for every mode: libpng writes the colour
// chunks it knows (gAMA, sRGB, cHRM, in that order) right after IHDR and the unknown chunks
// (cICP, mDCV, cLLI) after them, all before IDAT, which is what PNG 3rd edition asks of
// each (before PLTE and IDAT; no order among them).
TEST(PngWrite, ChunkOrderIsTheDocumentedOne) {
  using V = std::vector<std::string>;
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(ten_bit_frame(Mode::hdr10, 2, 2)))),
            (V{"IHDR", "cICP", "mDCV", "cLLI", "IDAT", "IEND"}));
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(ten_bit_frame(Mode::hlg, 2, 2)))),
            (V{"IHDR", "cICP", "mDCV", "cLLI", "IDAT", "IEND"}));
  EncodedFrame srgb = ten_bit_frame(Mode::sdr, 2, 2);
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(srgb))), (V{"IHDR", "gAMA", "sRGB", "cHRM", "cICP", "IDAT", "IEND"}));
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(eight_bit_frame(2, 2)))),
            (V{"IHDR", "gAMA", "sRGB", "cHRM", "cICP", "IDAT", "IEND"}));
  EncodedFrame g22 = ten_bit_frame(Mode::sdr, 2, 2);
  g22.target.sdr_curve = SdrCurve::gamma22;
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(g22))), (V{"IHDR", "gAMA", "cHRM", "cICP", "IDAT", "IEND"}));
  EXPECT_EQ(types(pngtest::chunks_of(*encode_png(ten_bit_frame(Mode::sdr_bt1886, 2, 2)))),
            (V{"IHDR", "gAMA", "cHRM", "cICP", "IDAT", "IEND"}));
}

TEST(PngWrite, EightBitSdrFromXrgb8888) {
  const EncodedFrame f = eight_bit_frame(5, 4);
  const auto png = encode_png(f);
  ASSERT_TRUE(png.ok()) << png.error().message;
  const auto cs = pngtest::chunks_of(*png);
  for (const auto& c : cs) EXPECT_TRUE(c.crc_ok) << c.type;
  EXPECT_EQ(find(cs, "IHDR")->data[8], 8);
  EXPECT_EQ(find(cs, "IHDR")->data[9], 2);
  ASSERT_NE(find(cs, "sRGB"), nullptr);
  EXPECT_EQ(find(cs, "sRGB")->data, (Bytes{0}));  // perceptual intent
  EXPECT_EQ(find(cs, "gAMA")->data, (Bytes{0, 0, 0xB1, 0x8F}));  // 45455, PNG §11.3.3.5 with sRGB
  EXPECT_EQ(find(cs, "cICP")->data, (Bytes{1, 13, 0, 1}));
  const auto d = pngtest::decode_rgb(*png);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) {
      EXPECT_EQ(d.samples[(y * 5 + x) * 3 + 0], 200 + x + y);  // R
      EXPECT_EQ(d.samples[(y * 5 + x) * 3 + 1], 100 + y);      // G
      EXPECT_EQ(d.samples[(y * 5 + x) * 3 + 2], 10 + x);       // B
    }
}

TEST(PngWrite, EightBitGammaCurvesUseGamaNotSrgb) {
  EncodedFrame f = eight_bit_frame(2, 2);
  f.target.sdr_curve = SdrCurve::gamma22;
  auto cs = pngtest::chunks_of(*encode_png(f));
  EXPECT_EQ(find(cs, "sRGB"), nullptr);
  EXPECT_EQ(find(cs, "gAMA")->data, (Bytes{0, 0, 0xB1, 0x8F}));  // 1/2.2 x 100000 = 45455
  EXPECT_NE(find(cs, "cHRM"), nullptr);
  f.target.mode = Mode::sdr_bt1886;
  cs = pngtest::chunks_of(*encode_png(f));
  EXPECT_EQ(find(cs, "gAMA")->data, (Bytes{0, 0, 0xA2, 0xC3}));  // 1/2.4 x 100000 = 41667
  EXPECT_EQ(find(cs, "cICP")->data, (Bytes{1, 1, 0, 1}));
}

TEST(PngWrite, ClliRoundsUpAndMdcvRounds) {
  EncodedFrame f = ten_bit_frame(Mode::hdr10, 2, 2);
  f.content_light = {100.00001, 0.00004};
  f.mastering.primaries = color::kRec2020;
  f.mastering.max_nits = 4000;
  f.mastering.min_nits = 0.0001;
  const auto cs = pngtest::chunks_of(*encode_png(f));
  // Whole cd/m2 rounded up, as the sidecar and HDR_OUTPUT_METADATA carry them: 100.00001 ->
  // 101 (1 010 000 = 0xF6950), 0.00004 -> 1 (10 000 = 0x2710), never 0 ("unknown").
  EXPECT_EQ(find(cs, "cLLI")->data, (Bytes{0x00, 0x0F, 0x69, 0x50, 0x00, 0x00, 0x27, 0x10}));
  const Bytes& m = find(cs, "mDCV")->data;
  EXPECT_EQ(pngtest::be32(&m[0]) >> 16, 35400u);  // 0.708 / 0.00002
  EXPECT_EQ(pngtest::be32(&m[16]), 40000000u);    // 4000 cd/m2
  EXPECT_EQ(pngtest::be32(&m[20]), 1u);           // 0.0001 cd/m2
}

TEST(PngWrite, ScrgbAndBrokenFramesAreErrors) {
  EncodedFrame s = ten_bit_frame(Mode::hdr10, 2, 2);
  s.target = default_target(Mode::scrgb);
  s.drm_fourcc = kDrmFormatAbgr16161616f;
  s.stride_bytes = 16;
  s.data.assign(32, 0);
  const auto e = encode_png(s);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.unsupported");
  EXPECT_NE(e.error().message.find("scrgb"), std::string::npos);

  EncodedFrame f = ten_bit_frame(Mode::hdr10, 3, 3);
  f.data.pop_back();
  EXPECT_EQ(encode_png(f).error().code, "frame.invalid");
  f = ten_bit_frame(Mode::hdr10, 3, 3);
  f.signal16.pop_back();
  EXPECT_EQ(encode_png(f).error().code, "frame.invalid");
  f = ten_bit_frame(Mode::hdr10, 3, 3);
  f.drm_fourcc = kDrmFormatXrgb8888;  // 8-bit buffer for an HDR10 frame
  EXPECT_EQ(encode_png(f).error().code, "frame.invalid");
}

TEST(PngWrite, WritePngIsAtomic) {
  testing::TempDir tmp;
  ASSERT_TRUE(write_png(tmp / "a.png", ten_bit_frame(Mode::hdr10, 4, 4)).ok());
  EXPECT_TRUE(read_png_info(tmp / "a.png").ok());
  EXPECT_FALSE(write_png(tmp / "missing-dir" / "a.png", ten_bit_frame(Mode::hdr10, 4, 4)).ok());
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(tmp.path())) ++files;
  EXPECT_EQ(files, 1);
}

}  // namespace
}  // namespace hdrd::io

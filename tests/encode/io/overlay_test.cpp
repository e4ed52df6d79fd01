// UI overlay PNG decoding: every colour type and bit depth, crafted byte by byte with the
// test's own encoder (tests/encode/io/png_util.hpp), expected floats worked out from the samples.
#include <gtest/gtest.h>

#include "encode/io/io.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

using Bytes = std::vector<std::uint8_t>;
using pngtest::Spec;

void expect_pixel(const OverlayImage& img, int x, int y, std::array<float, 4> want, const char* what) {
  const float* p = img.rgba.data() + (static_cast<std::size_t>(y) * img.width + x) * 4;
  for (int c = 0; c < 4; ++c) EXPECT_FLOAT_EQ(p[c], want[static_cast<std::size_t>(c)]) << what << " (" << x << "," << y << ") c" << c;
}

TEST(Overlay, PaletteWithTrns) {
  Spec s{2, 1, 8, 3, false, {{"PLTE", {255, 0, 0, 0, 128, 255}}, {"tRNS", {64}}}};
  const auto img = read_overlay_png_memory(pngtest::encode(s, {0, 1}));
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(img->width, 2);
  EXPECT_FALSE(img->premultiplied);
  expect_pixel(*img, 0, 0, {1, 0, 0, 64 / 255.0f}, "palette entry 0, alpha from tRNS");
  expect_pixel(*img, 1, 0, {0, 128 / 255.0f, 1, 1}, "palette entry 1, no tRNS entry: opaque");
}

TEST(Overlay, OneBitGrey) {
  Spec s{9, 1, 1, 0, false, {}};
  const auto img = read_overlay_png_memory(pngtest::encode(s, {0b10100000, 0b10000000}));
  ASSERT_TRUE(img.ok()) << img.error().message;
  expect_pixel(*img, 0, 0, {1, 1, 1, 1}, "bit 1");
  expect_pixel(*img, 1, 0, {0, 0, 0, 1}, "bit 0");
  expect_pixel(*img, 8, 0, {1, 1, 1, 1}, "second byte");
}

TEST(Overlay, SixteenBitGreyAndGreyAlpha) {
  Spec g16{1, 2, 16, 0, false, {}};
  auto img = read_overlay_png_memory(pngtest::encode(g16, {0x80, 0x00, 0xff, 0xff}));
  ASSERT_TRUE(img.ok()) << img.error().message;
  const float half_grey = 0x8000 / 65535.0f;
  expect_pixel(*img, 0, 0, {half_grey, half_grey, half_grey, 1}, "16-bit grey");
  expect_pixel(*img, 0, 1, {1, 1, 1, 1}, "16-bit white");

  Spec ga8{1, 1, 8, 4, false, {}};
  img = read_overlay_png_memory(pngtest::encode(ga8, {51, 204}));
  ASSERT_TRUE(img.ok());
  expect_pixel(*img, 0, 0, {0.2f, 0.2f, 0.2f, 0.8f}, "grey + alpha, straight");
}

TEST(Overlay, RgbWithColourKeyAndSixteenBitRgba) {
  Spec rgb{2, 1, 8, 2, false, {{"tRNS", {0, 10, 0, 20, 0, 30}}}};
  auto img = read_overlay_png_memory(pngtest::encode(rgb, {10, 20, 30, 10, 20, 31}));
  ASSERT_TRUE(img.ok()) << img.error().message;
  EXPECT_FLOAT_EQ(img->rgba[3], 0.0f);  // the key colour is transparent
  EXPECT_FLOAT_EQ(img->rgba[7], 1.0f);

  Spec rgba16{1, 1, 16, 6, false, {}};
  img = read_overlay_png_memory(pngtest::encode(rgba16, {0xff, 0xff, 0x00, 0x01, 0x12, 0x34, 0x80, 0x00}), true);
  ASSERT_TRUE(img.ok());
  EXPECT_TRUE(img->premultiplied);  // declared by the caller, values untouched
  expect_pixel(*img, 0, 0, {1, 1 / 65535.0f, 0x1234 / 65535.0f, 0x8000 / 65535.0f}, "16-bit RGBA");
}

TEST(Overlay, Adam7Interlaced) {
  const int w = 11, h = 9;
  Bytes rows;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) rows.push_back(static_cast<std::uint8_t>(x * 20 + y * 3 + c));
  Spec s{w, h, 8, 2, true, {}};
  const auto img = read_overlay_png_memory(pngtest::encode(s, rows));
  ASSERT_TRUE(img.ok()) << img.error().message;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      expect_pixel(*img, x, y, {(x * 20 + y * 3) / 255.0f, (x * 20 + y * 3 + 1) / 255.0f, (x * 20 + y * 3 + 2) / 255.0f, 1},
                   "interlaced");
}

Bytes small_rgba() {
  Spec s{4, 4, 8, 6, false, {}};
  return pngtest::encode(s, Bytes(64, 0x80));
}

TEST(OverlayBadInput, NotPngTruncatedCorruptMissing) {
  EXPECT_EQ(read_overlay_png_memory(Bytes{'G', 'I', 'F', '8', '9', 'a', 0, 0, 0}).error().code, "png.not_png");
  EXPECT_EQ(read_overlay_png_memory(Bytes{}).error().code, "png.not_png");
  const Bytes good = small_rgba();
  ASSERT_TRUE(read_overlay_png_memory(good).ok());
  for (std::size_t cut : {std::size_t{8}, std::size_t{20}, std::size_t{33}, std::size_t{40}, good.size() - 13, good.size() - 1}) {
    const auto e = read_overlay_png_memory(std::span(good.data(), cut));
    ASSERT_FALSE(e.ok()) << cut;
    EXPECT_EQ(e.error().code, "png.truncated") << cut << ": " << e.error().message;
  }
  Bytes bad = good;
  bad[8 + 25 + 10] ^= 0xff;  // inside the IDAT data (libpng inflates before it checks the CRC)
  auto e = read_overlay_png_memory(bad);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.corrupt");
  bad = good;
  bad[good.size() - 12 - 1] ^= 0xff;  // the IDAT CRC itself (IEND is the last 12 bytes)
  e = read_overlay_png_memory(bad);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.corrupt");
  EXPECT_NE(e.error().message.find("CRC"), std::string::npos) << e.error().message;

  testing::TempDir tmp;
  const auto m = read_overlay_png(tmp / "ui.png");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, "png.missing");
  EXPECT_NE(m.error().message.find("ui.png"), std::string::npos);
}

TEST(OverlayBadInput, CorruptZlibStreamWithValidCrcs) {
  Spec s{4, 4, 8, 6, false, {}};
  Bytes png(pngtest::kSignature.begin(), pngtest::kSignature.end());
  pngtest::append_chunk(png, "IHDR", {0, 0, 0, 4, 0, 0, 0, 4, 8, 6, 0, 0, 0});
  pngtest::append_chunk(png, "IDAT", {0x78, 0x9c, 0xff, 0xff, 0xff, 0xff, 0x00, 0x11});  // not deflate
  pngtest::append_chunk(png, "IEND", {});
  const auto e = read_overlay_png_memory(png);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.corrupt") << e.error().message;
}

// IHDR with a patched size (CRC recomputed so only the size is wrong).
Bytes with_size(std::uint32_t w, std::uint32_t h) {
  Bytes png(pngtest::kSignature.begin(), pngtest::kSignature.end());
  Bytes ihdr;
  pngtest::put_be32(ihdr, w);
  pngtest::put_be32(ihdr, h);
  ihdr.insert(ihdr.end(), {8, 6, 0, 0, 0});
  pngtest::append_chunk(png, "IHDR", ihdr);
  pngtest::append_chunk(png, "IDAT", pngtest::zlib_compress(Bytes(5, 0)));
  pngtest::append_chunk(png, "IEND", {});
  return png;
}

TEST(OverlayBadInput, AbsurdSizesAreRejectedBeforeAllocating) {
  auto e = read_overlay_png_memory(with_size(100000, 1));
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.size") << e.error().message;
  e = read_overlay_png_memory(with_size(16384, 16384));  // each side allowed, the area is not
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.size") << e.error().message;
  e = read_overlay_png_memory(with_size(0, 5));
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(read_png_info_memory(with_size(100000, 1)).error().code, "png.size");
}

// png_fuzz (2 Dec): a 101-byte file whose second chunk, an sPLT, declares 1 610 612 742
// bytes made libpng allocate that much before reading. Every chunk's length is now checked
// against the bytes left, for every chunk type, before libpng runs.
TEST(OverlayBadInput, AChunkLongerThanTheFileIsRefusedBeforeLibpngAllocatesIt) {
  Spec s{2, 2, 8, 2, false, {}};
  const Bytes good = pngtest::encode(s, std::vector<std::uint8_t>(14, 0));  // 2 rows: filter byte + 6
  ASSERT_TRUE(read_overlay_png_memory(good).ok());
  for (const char* type : {"sPLT", "iCCP", "zTXt", "IDAT", "abCd"}) {
    Bytes bad(good.begin(), good.begin() + 33);  // signature + IHDR
    const std::uint32_t n = 0x60000006u;
    for (int k = 3; k >= 0; --k) bad.push_back(static_cast<std::uint8_t>(n >> (8 * k)));
    bad.insert(bad.end(), type, type + 4);
    bad.insert(bad.end(), {0xff, 0, 0, 0, 0x80, 0xff, 1, 2, 3, 4});
    auto e = read_overlay_png_memory(bad);
    ASSERT_FALSE(e.ok()) << type;
    EXPECT_EQ(e.error().code, "png.truncated") << type;
    EXPECT_NE(e.error().message.find(std::string(type) + " chunk declares 1610612742 bytes, 6 are left"), std::string::npos)
        << e.error().message;
    EXPECT_EQ(read_png_info_memory(bad).error().code, "png.truncated") << type;
  }
}

// Issue 14: a 21 KB PNG declaring 16384 x 8192 decoded to 4.3 GB. A caller's limits are
// checked against the declared size (IHDR) before libpng allocates or inflates anything.
TEST(OverlayBadInput, DeclaredSizeIsCheckedAgainstTheCallersLimits) {
  const Bytes huge = with_size(16384, 8192);  // within image.hpp's own limits
  const auto h = png_header(huge);
  ASSERT_TRUE(h.has_value());
  EXPECT_EQ(h->width, 16384u);
  EXPECT_EQ(h->height, 8192u);
  const PngLimits frame{7680, 4320, 7680LL * 4320LL};
  auto e = read_overlay_png_memory(huge, false, frame);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "png.size");
  EXPECT_NE(e.error().message.find("declares 16384x8192"), std::string::npos) << e.error().message;
  e = read_overlay_png_memory(with_size(2000, 2000), false, PngLimits{4096, 4096, 1 << 20});
  ASSERT_FALSE(e.ok()) << "each side within, the area not";
  EXPECT_EQ(e.error().code, "png.size");
  Spec s{2, 1, 8, 6, false, {}};
  EXPECT_TRUE(read_overlay_png_memory(pngtest::encode(s, {0, 1, 2, 3, 4, 5, 6, 7, 8}), false, PngLimits{2, 1, 2}).ok());
  EXPECT_FALSE(read_overlay_png_memory(pngtest::encode(s, {0, 1, 2, 3, 4, 5, 6, 7, 8}), false, PngLimits{1, 1, 1}).ok());
  EXPECT_FALSE(png_header(Bytes{1, 2, 3}).has_value());
  EXPECT_EQ(overlay_decode_bytes(100, 10), 100u * 10u * 24u);
}

}  // namespace
}  // namespace hdrd::io

// EXR reading of channel sets, tilings, windows and compressions the fixtures lack (files
// written here with OpenEXR's own writer), hdrd's EXR writer checked with OpenEXR's own
// reader, and bad input.
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfTiledOutputFile.h>
#include <Imath/half.h>

#include "encode/io/io.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// A smooth, non-symmetric test pattern: channel c of pixel (x, y).
float pattern(int x, int y, int c) { return 0.25f * x - 0.125f * y + 0.5f * c + 0.0625f * (x * y % 7); }

struct Plane {
  std::string name;
  Imf::PixelType type = Imf::FLOAT;
  std::vector<float> f;
  std::vector<unsigned> u;
};

// Writes a scanline file with the given channels and data window, using OpenEXR directly.
void write_planes(const fs::path& path, const Imath::Box2i& dw, const Imath::Box2i& display,
                  std::vector<Plane>& planes, Imf::Compression compression = Imf::ZIP_COMPRESSION) {
  Imf::Header h(display, dw);
  h.compression() = compression;
  Imf::FrameBuffer fb;
  for (auto& p : planes) {
    h.channels().insert(p.name, Imf::Channel(p.type));
    char* base = p.type == Imf::UINT ? reinterpret_cast<char*>(p.u.data()) : reinterpret_cast<char*>(p.f.data());
    fb.insert(p.name, Imf::Slice::Make(p.type == Imf::UINT ? Imf::UINT : Imf::FLOAT, base, dw));
  }
  Imf::OutputFile out(path.c_str(), h);
  out.setFrameBuffer(fb);
  out.writePixels(dw.max.y - dw.min.y + 1);
}

Plane plane(const std::string& name, int w, int h, int c) {
  Plane p{name, Imf::FLOAT, {}, {}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p.f.push_back(pattern(x, y, c));
  return p;
}

bool any_warning(const ExrImage& e, const std::string& needle) {
  for (const auto& w : e.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

TEST(ExrRead, DataWindowNotAtOriginUsesTheDataWindow) {
  TempDir tmp;
  const Imath::Box2i dw({10, 20}, {17, 25}), display({0, 0}, {31, 31});
  std::vector<Plane> planes{plane("R", 8, 6, 0), plane("G", 8, 6, 1), plane("B", 8, 6, 2), plane("A", 8, 6, 3)};
  write_planes(tmp / "dw.exr", dw, display, planes);
  const auto e = read_exr(tmp / "dw.exr");
  ASSERT_TRUE(e.ok()) << e.error().message;
  ASSERT_EQ(e->image.width, 8);
  ASSERT_EQ(e->image.height, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 4; ++c) ASSERT_EQ(e->image.px(x, y)[c], pattern(x, y, c)) << x << "," << y << "," << c;
  EXPECT_TRUE(any_warning(*e, "using the data window"));
}

TEST(ExrRead, TiledAndMipmappedFilesReadLevelZero) {
  TempDir tmp;
  for (Imf::LevelMode mode : {Imf::ONE_LEVEL, Imf::MIPMAP_LEVELS}) {
    const int w = 13, h = 9;
    Imf::Header header(w, h);
    header.setTileDescription(Imf::TileDescription(4, 4, mode));
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::HALF));
    const fs::path path = tmp / (mode == Imf::ONE_LEVEL ? "tiled.exr" : "mip.exr");
    {
      Imf::TiledOutputFile out(path.c_str(), header);
      for (int level = 0; level < out.numLevels(); ++level) {
        const int lw = out.levelWidth(level), lh = out.levelHeight(level);
        std::vector<half> px(static_cast<std::size_t>(lw) * lh * 3);
        for (int y = 0; y < lh; ++y)
          for (int x = 0; x < lw; ++x)
            for (int c = 0; c < 3; ++c) px[(static_cast<std::size_t>(y) * lw + x) * 3 + c] = half(pattern(x, y, c) + level);
        Imf::FrameBuffer fb;
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c)
          fb.insert(names[c], Imf::Slice(Imf::HALF, reinterpret_cast<char*>(px.data() + c), 6, 6 * static_cast<std::size_t>(lw)));
        out.setFrameBuffer(fb);
        out.writeTiles(0, out.numXTiles(level) - 1, 0, out.numYTiles(level) - 1, level);
      }
    }
    const auto e = read_exr(path);
    ASSERT_TRUE(e.ok()) << e.error().message;
    ASSERT_EQ(e->image.width, w);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) ASSERT_EQ(e->image.px(x, y)[c], float(half(pattern(x, y, c))));
  }
}

// Luminance/chroma files: OpenEXR's RgbaInputFile is the reference reconstruction.
TEST(ExrRead, LuminanceChromaMatchesOpenExrsOwnReconstruction) {
  TempDir tmp;
  const int w = 16, h = 8;
  std::vector<Imf::Rgba> src(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      src[static_cast<std::size_t>(y) * w + x] = Imf::Rgba(0.1f + 0.05f * x, 0.2f + 0.03f * y, 0.3f, 1.0f);
  const fs::path path = tmp / "yc.exr";
  {
    Imf::RgbaOutputFile out(path.c_str(), w, h, Imf::WRITE_YC);
    out.setFrameBuffer(src.data(), 1, w);
    out.writePixels(h);
  }
  std::vector<Imf::Rgba> ref(src.size());
  {
    Imf::RgbaInputFile in(path.c_str());
    in.setFrameBuffer(ref.data(), 1, w);
    in.readPixels(0, h - 1);
  }
  const auto e = read_exr(path);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_NE(std::find(e->channels.begin(), e->channels.end(), "RY"), e->channels.end());
  for (std::size_t i = 0; i < ref.size(); ++i) {
    EXPECT_EQ(e->image.rgba[i * 4 + 0], float(ref[i].r));
    EXPECT_EQ(e->image.rgba[i * 4 + 1], float(ref[i].g));
    EXPECT_EQ(e->image.rgba[i * 4 + 2], float(ref[i].b));
    EXPECT_EQ(e->image.rgba[i * 4 + 3], 1.0f);
  }
}

TEST(ExrRead, ChannelSets) {
  TempDir tmp;
  const Imath::Box2i win({0, 0}, {3, 2});
  {
    std::vector<Plane> p{plane("R", 4, 3, 0), plane("G", 4, 3, 1)};
    write_planes(tmp / "rg.exr", win, win, p);
    const auto e = read_exr(tmp / "rg.exr");
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_EQ(e->image.px(2, 1)[0], pattern(2, 1, 0));
    EXPECT_EQ(e->image.px(2, 1)[2], 0.0f);
    EXPECT_EQ(e->image.px(2, 1)[3], 1.0f);
    EXPECT_TRUE(any_warning(*e, "B missing"));
  }
  {
    std::vector<Plane> p{plane("diffuse.R", 4, 3, 0), plane("diffuse.G", 4, 3, 1), plane("diffuse.B", 4, 3, 2),
                         plane("depth.Z", 4, 3, 3)};
    write_planes(tmp / "layer.exr", win, win, p);
    const auto e = read_exr(tmp / "layer.exr");
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_EQ(e->image.px(3, 2)[1], pattern(3, 2, 1));
    EXPECT_TRUE(any_warning(*e, "using layer 'diffuse'"));
  }
  {
    std::vector<Plane> p{plane("Y", 4, 3, 0), plane("A", 4, 3, 3)};
    write_planes(tmp / "ya.exr", win, win, p);
    const auto e = read_exr(tmp / "ya.exr");
    ASSERT_TRUE(e.ok()) << e.error().message;
    const float* px = e->image.px(1, 2);
    EXPECT_TRUE(px[0] == pattern(1, 2, 0) && px[1] == px[0] && px[2] == px[0]);
    EXPECT_EQ(px[3], pattern(1, 2, 3));
  }
  {
    Plane u{"R", Imf::UINT, {}, {}};
    for (int i = 0; i < 12; ++i) u.u.push_back(1000u * i);
    std::vector<Plane> p{u, plane("G", 4, 3, 1), plane("B", 4, 3, 2)};
    write_planes(tmp / "uint.exr", win, win, p);
    const auto e = read_exr(tmp / "uint.exr");
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_EQ(e->image.px(3, 2)[0], 11000.0f);
  }
  {
    std::vector<Plane> p{plane("Z", 4, 3, 0), plane("depth", 4, 3, 1)};
    write_planes(tmp / "z.exr", win, win, p);
    const auto e = read_exr(tmp / "z.exr");
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, "exr.channels");
    EXPECT_NE(e.error().message.find("no usable channels (has: Z, depth"), std::string::npos) << e.error().message;
    EXPECT_NE(e.error().message.find("z.exr"), std::string::npos);
  }
}

TEST(ExrRead, DegenerateChromaticitiesAreIgnoredWithAWarning) {
  TempDir tmp;
  Imf::Header h(2, 2);
  Imf::addChromaticities(h, Imf::Chromaticities({0.3f, 0.3f}, {0.3f, 0.3f}, {0.3f, 0.3f}, {0.3127f, 0.329f}));
  Imf::addWhiteLuminance(h, -5.0f);
  std::vector<Imf::Rgba> px(4, Imf::Rgba(1, 1, 1, 1));
  {
    Imf::RgbaOutputFile out((tmp / "degenerate.exr").c_str(), h, Imf::WRITE_RGB);
    out.setFrameBuffer(px.data(), 1, 2);
    out.writePixels(2);
  }
  const auto e = read_exr(tmp / "degenerate.exr");
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_FALSE(e->chromaticities.has_value());
  EXPECT_FALSE(e->white_luminance.has_value());
  EXPECT_TRUE(any_warning(*e, "ignoring degenerate chromaticities"));
  EXPECT_TRUE(any_warning(*e, "ignoring whiteLuminance -5"));
  EXPECT_NEAR(e->to_working().m[0][0], color::kBt2087Rec709ToRec2020.m[0][0], 1e-4);  // treated as Rec.709
}

TEST(ExrRead, MultiPartReadsTheFirstImagePart) {
  TempDir tmp;
  const int w = 4, h = 2;
  std::vector<Imf::Header> headers(2, Imf::Header(w, h));
  for (int i = 0; i < 2; ++i) {
    headers[static_cast<std::size_t>(i)].setName(i == 0 ? "beauty" : "other");
    headers[static_cast<std::size_t>(i)].setType(Imf::SCANLINEIMAGE);
    for (const char* c : {"R", "G", "B"}) headers[static_cast<std::size_t>(i)].channels().insert(c, Imf::Channel(Imf::FLOAT));
  }
  const fs::path path = tmp / "multi.exr";
  {
    Imf::MultiPartOutputFile out(path.c_str(), headers.data(), 2);
    for (int part = 0; part < 2; ++part) {
      std::vector<float> px(static_cast<std::size_t>(w) * h * 3, part == 0 ? 0.5f : 7.0f);
      Imf::FrameBuffer fb;
      const char* names[3] = {"R", "G", "B"};
      for (int c = 0; c < 3; ++c)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data() + c), 12, 12 * w));
      Imf::OutputPart op(out, part);
      op.setFrameBuffer(fb);
      op.writePixels(h);
    }
  }
  const auto e = read_exr(path);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_EQ(e->image.px(3, 1)[2], 0.5f);
  EXPECT_TRUE(any_warning(*e, "multi-part file (2 parts)"));
}

// Every compression OpenEXR 3.1 has, written by OpenEXR, read by hdrd: lossless ones
// exactly, lossy ones within their documented loss.
TEST(ExrRead, EveryCompression) {
  TempDir tmp;
  const int w = 37, h = 21;  // not a multiple of any block size
  const Imath::Box2i win({0, 0}, {w - 1, h - 1});
  // {compression, relative tolerance, tolerance as a fraction of the image's largest value}
  struct Case { Imf::Compression compression; double rel, of_max; };
  const Case cases[] = {
      {Imf::NO_COMPRESSION, 0, 0},   {Imf::RLE_COMPRESSION, 0, 0}, {Imf::ZIPS_COMPRESSION, 0, 0},
      {Imf::ZIP_COMPRESSION, 0, 0},  {Imf::PIZ_COMPRESSION, 0, 0},
      {Imf::PXR24_COMPRESSION, 1e-4, 0},  // float32 rounded to 24 bits: 2^-15 relative
      {Imf::B44_COMPRESSION, 0, 0},  {Imf::B44A_COMPRESSION, 0, 0},  // B44 only touches HALF channels
      // DWA quantises R, G, B in a DCT (level 45): about 1 % of the block's range here.
      {Imf::DWAA_COMPRESSION, 0, 0.02}, {Imf::DWAB_COMPRESSION, 0, 0.02},
  };
  double largest = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) largest = std::max(largest, std::abs(double(pattern(x, y, c))));
  for (const Case& k : cases) {
    std::vector<Plane> p{plane("R", w, h, 0), plane("G", w, h, 1), plane("B", w, h, 2)};
    const fs::path path = tmp / ("c" + std::to_string(int(k.compression)) + ".exr");
    write_planes(path, win, win, p, k.compression);
    const auto e = read_exr(path);
    ASSERT_TRUE(e.ok()) << e.error().message;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          const double ref = pattern(x, y, c);
          ASSERT_NEAR(e->image.px(x, y)[c], ref, k.rel * std::abs(ref) + k.of_max * largest)
              << "compression " << e->compression;
        }
  }
}

// ---- writing ----------------------------------------------------------------------------

Image test_image(int w, int h, bool alpha) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 4; ++c) img.px(x, y)[c] = c == 3 ? (alpha ? 0.25f * (x % 4) : 1.0f) : pattern(x, y, c) * 3.1f;
  return img;
}

TEST(ExrWrite, OpenExrReadsBackChannelsAttributesAndHalfRounding) {
  TempDir tmp;
  Image img = test_image(9, 5, false);
  img.px(0, 0)[0] = 0.001f;   // half(0.001f) is 0x1419 (round to nearest even)
  img.px(1, 0)[0] = 1000.0f;
  ExrWriteOptions opt;
  opt.chromaticities = color::kRec2020;
  opt.white_luminance = 203.0;
  opt.attributes = {{"tonemap", "bt2390"}, {"exposure_ev", "0.5"}};
  opt.compression = "piz";
  const auto written = write_exr(tmp / "w.exr", img, opt);
  ASSERT_TRUE(written.ok()) << written.error().message;

  Imf::InputFile in((tmp / "w.exr").c_str());
  const Imf::Header& h = in.header();
  EXPECT_EQ(h.compression(), Imf::PIZ_COMPRESSION);
  EXPECT_EQ(h.channels().findChannel("A"), nullptr);  // all alpha 1: no A channel
  ASSERT_NE(h.channels().findChannel("R"), nullptr);
  EXPECT_EQ(h.channels().findChannel("R")->type, Imf::HALF);
  ASSERT_TRUE(Imf::hasChromaticities(h));
  EXPECT_FLOAT_EQ(Imf::chromaticities(h).green.y, 0.797f);
  EXPECT_FLOAT_EQ(Imf::whiteLuminance(h), 203.0f);
  const auto* tm = h.findTypedAttribute<Imf::StringAttribute>("hdrd:tonemap");
  ASSERT_NE(tm, nullptr);
  EXPECT_EQ(tm->value(), "bt2390");

  std::vector<half> r(img.pixel_count());
  Imf::FrameBuffer fb;
  fb.insert("R", Imf::Slice(Imf::HALF, reinterpret_cast<char*>(r.data()), sizeof(half), sizeof(half) * 9));
  in.setFrameBuffer(fb);
  in.readPixels(0, 4);
  EXPECT_EQ(r[0].bits(), 0x1419);
  EXPECT_EQ(float(r[1]), 1000.0f);
  for (std::size_t i = 0; i < r.size(); ++i) EXPECT_EQ(r[i].bits(), half(img.rgba[i * 4]).bits());
}

TEST(ExrWrite, FloatXyzAlphaAndEveryCompressionRoundTrip) {
  TempDir tmp;
  const Image img = test_image(19, 7, true);
  const double largest = std::abs(*std::max_element(img.rgba.begin(), img.rgba.end(),
                                                    [](float a, float b) { return std::abs(a) < std::abs(b); }));
  for (const char* comp : {"none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"}) {
    ExrWriteOptions opt;
    opt.half = false;
    opt.xyz = true;
    opt.compression = comp;
    const auto bytes = encode_exr(img, opt);
    ASSERT_TRUE(bytes.ok()) << bytes.error().message;
    const auto e = read_exr_memory(*bytes);
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_TRUE(e->is_xyz);
    EXPECT_EQ(e->compression, comp);
    // Lossless except PXR24 (24-bit floats) and DWA (DCT on R, G, B; A is kept exactly).
    const std::string c = comp;
    const double rel = c == "pxr24" ? 1e-4 : 0, of_max = c.rfind("dwa", 0) == 0 ? 0.02 * largest : 0;
    for (std::size_t i = 0; i < img.rgba.size(); ++i)
      ASSERT_NEAR(e->image.rgba[i], img.rgba[i], rel * std::abs(img.rgba[i]) + (i % 4 == 3 ? 0 : of_max))
          << comp << " sample " << i;
  }
}

TEST(ExrWrite, RejectsBadOptionsAndImages) {
  Image img = test_image(4, 4, false);
  ExrWriteOptions opt;
  opt.compression = "lzma";
  const auto bad = encode_exr(img, opt);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "compression");
  img.rgba.pop_back();
  EXPECT_FALSE(encode_exr(img, ExrWriteOptions{}).ok());
  EXPECT_FALSE(encode_exr(Image(0, 3), ExrWriteOptions{}).ok());
}

// ---- bad input --------------------------------------------------------------------------

std::vector<std::uint8_t> bytes_of(const fs::path& p) {
  const std::string s = testing::read_file(p);
  return {s.begin(), s.end()};
}

void write_bytes(const fs::path& p, const std::vector<std::uint8_t>& b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

TEST(ExrBadInput, MissingDirectoryAndNotAnExr) {
  TempDir tmp;
  auto e = read_exr(tmp / "nope.exr");
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "exr.missing");
  EXPECT_NE(e.error().message.find("nope.exr"), std::string::npos);

  e = read_exr(tmp.path());  // the file model's refusal (encode/io/beneath.hpp)
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "path.not_regular");

  write_bytes(tmp / "text.exr", {'h', 'e', 'l', 'l', 'o', '\n'});
  e = read_exr(tmp / "text.exr");
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, "exr.not_exr");
  EXPECT_EQ(e.error().message.find('\n'), std::string::npos);

  write_bytes(tmp / "empty.exr", {});
  EXPECT_EQ(read_exr(tmp / "empty.exr").error().code, "exr.not_exr");
  EXPECT_EQ(read_exr_memory({}).error().code, "exr.not_exr");
}

TEST(ExrBadInput, TruncatedAnywhereIsAnError) {
  HDRD_REQUIRE_FIXTURE(desk, "fixtures/exr/Desk.exr");
  const auto full = bytes_of(desk);
  for (std::size_t cut : {std::size_t{4}, std::size_t{20}, std::size_t{300}, std::size_t{2000}, full.size() / 2,
                          full.size() - 100, full.size() - 1}) {
    const auto e = read_exr_memory(std::span(full.data(), cut));
    ASSERT_FALSE(e.ok()) << "cut at " << cut;
    EXPECT_TRUE(e.error().code == "exr.truncated" || e.error().code == "exr.corrupt") << e.error().code;
    EXPECT_EQ(e.error().message.find('\n'), std::string::npos);
  }
  const auto mid = read_exr_memory(std::span(full.data(), full.size() / 2));
  EXPECT_EQ(mid.error().code, "exr.truncated") << mid.error().message;
  TempDir tmp;
  write_bytes(tmp / "cut.exr", std::vector<std::uint8_t>(full.begin(), full.begin() + 5000));
  const auto f = read_exr(tmp / "cut.exr");
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("cut.exr"), std::string::npos) << f.error().message;
}

// Finds a header attribute's value bytes ("name\0type\0" + u32 size + value).
std::size_t attribute_value(const std::vector<std::uint8_t>& b, const std::string& name, const std::string& type) {
  std::string key = name;
  key.push_back('\0');
  key += type;
  key.push_back('\0');
  const auto it = std::search(b.begin(), b.end(), key.begin(), key.end());
  EXPECT_NE(it, b.end()) << name;
  return static_cast<std::size_t>(it - b.begin()) + key.size() + 4;
}

void put_i32(std::vector<std::uint8_t>& b, std::size_t at, std::int32_t v) {
  std::memcpy(b.data() + at, &v, 4);  // EXR is little-endian, as is the host
}

TEST(ExrBadInput, AbsurdSizesAreRejectedBeforeAllocating) {
  HDRD_REQUIRE_FIXTURE(desk, "fixtures/exr/Desk.exr");
  const auto good = bytes_of(desk);
  const std::size_t dw = attribute_value(good, "dataWindow", "box2i");
  const std::size_t disp = attribute_value(good, "displayWindow", "box2i");
  {
    auto b = good;  // 1,000,000 pixels wide
    put_i32(b, dw + 8, 999999);
    put_i32(b, disp + 8, 999999);
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, "exr.size") << e.error().message;
  }
  {
    auto b = good;  // 16384 x 16384: each side allowed, the area is not
    put_i32(b, dw + 8, 16383);
    put_i32(b, dw + 12, 16383);
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, "exr.size") << e.error().message;
    EXPECT_NE(e.error().message.find("16384x16384"), std::string::npos) << e.error().message;
  }
  {
    auto b = good;  // max < min
    put_i32(b, dw + 8, -5);
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
  }
}

// OpenEXR 3.1.5 allocates whatever a header declares before reading it (found by
// tests/fuzz/exr_fuzz); hdrd checks the declarations against the bytes present first.
TEST(ExrBadInput, HeaderDeclarationsBeyondTheFileAreRejectedUpFront) {
  ExrWriteOptions opt;
  const auto small = encode_exr(test_image(4, 4, false), opt);
  ASSERT_TRUE(small.ok());
  {
    auto b = *small;  // an attribute that claims 2 GiB
    put_i32(b, attribute_value(b, "screenWindowWidth", "float") - 4, 0x7fffffff);
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
    EXPECT_NE(e.error().message.find("attribute 'screenWindowWidth' claims 2147483647 bytes"), std::string::npos)
        << e.error().message;
  }
  // The fuzzer's regressions: 1.6 and 1.7 GB claims on early attributes, whole and cut short.
  for (const std::int32_t claim : {1'600'000'000, 1'700'000'000})
    for (const auto& [name, type] : {std::pair{"dataWindow", "box2i"}, std::pair{"compression", "compression"}})
      for (const bool cut : {false, true}) {
        auto b = *small;
        const std::size_t at = attribute_value(b, name, type);
        put_i32(b, at - 4, claim);
        if (cut) b.resize(at + 16);
        const auto e = read_exr_memory(b);
        ASSERT_FALSE(e.ok()) << name << " " << claim << (cut ? " cut" : "");
        EXPECT_EQ(e.error().message.find('\n'), std::string::npos);
      }
  {
    auto b = *small;  // a legal 16000 x 8000 window in a file of a few hundred bytes
    const std::size_t dw = attribute_value(b, "dataWindow", "box2i");
    put_i32(b, dw + 8, 15999);
    put_i32(b, dw + 12, 7999);
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, "exr.truncated") << e.error().message;
    EXPECT_NE(e.error().message.find("needs 500 chunk offsets"), std::string::npos) << e.error().message;  // ZIP: 16 lines
  }
}

TEST(ExrBadInput, CorruptHeaderAndDataAreErrorsNotCrashes) {
  HDRD_REQUIRE_FIXTURE(desk, "fixtures/exr/Desk.exr");
  const auto good = bytes_of(desk);
  {
    auto b = good;
    b[attribute_value(good, "compression", "compression")] = 42;  // no such compression
    const auto e = read_exr_memory(b);
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.error().code, "exr.corrupt") << e.error().message;
  }
  {
    auto b = good;  // scramble the line offset table and some pixel data
    const std::size_t end_of_header = attribute_value(good, "screenWindowWidth", "float") + 5;
    for (std::size_t i = end_of_header; i < end_of_header + 4000 && i < b.size(); i += 7) b[i] ^= 0x5a;
    const auto e = read_exr_memory(b);
    if (!e.ok()) {
      EXPECT_TRUE(e.error().code == "exr.corrupt" || e.error().code == "exr.truncated") << e.error().message;
    }
  }
}

TEST(ExrRead, MemoryAndFileGiveTheSamePixels) {
  HDRD_REQUIRE_FIXTURE(desk, "fixtures/exr/Desk.exr");
  const auto a = read_exr(desk);
  const auto bytes = bytes_of(desk);
  const auto b = read_exr_memory(bytes);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(std::memcmp(a->image.rgba.data(), b->image.rgba.data(), a->image.rgba.size() * 4), 0);
}

}  // namespace
}  // namespace hdrd::io

// Half-float EXR paths: files decoded straight into half pixels, written from half pixels,
// and the float-to-half conversion, each against OpenEXR's own reader or Imath's `half`
// (the reference conversion, IEEE 754 binary16 round to nearest even), on images large
// enough that OpenEXR's thread pool splits them into many chunks.
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>

#include <gtest/gtest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfThreading.h>
#include <Imath/half.h>

#include "encode/io/io.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// Every finite and special half value somewhere in the image, then a smooth pattern.
ImageHalf half_pattern(int w, int h, bool alpha) {
  ImageHalf img(w, h);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) {
    const bool a = i % 4 == 3;
    img.rgba[i] = a ? (alpha ? half(0.25f * static_cast<float>(i % 5)).bits() : half(1.0f).bits())
                    : static_cast<std::uint16_t>(i < 4 * 65536 ? i / 4 * 3 % 65536 : (i * 2654435761u) >> 20);
  }
  return img;
}

// OpenEXR's own reader, half channels as stored; absent A reads as 1.0.
ImageHalf openexr_read_half(const fs::path& path) {
  Imf::InputFile in(path.c_str());
  const auto dw = in.header().dataWindow();
  ImageHalf img(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1);
  Imf::FrameBuffer fb;
  const char* names[4] = {"R", "G", "B", "A"};
  for (int c = 0; c < 4; ++c)
    fb.insert(names[c], Imf::Slice::Make(Imf::HALF, img.rgba.data() + c, dw, 8, 8 * static_cast<std::size_t>(img.width),
                                         1, 1, c == 3 ? 1.0 : 0.0));
  in.setFrameBuffer(fb);
  in.readPixels(dw.min.y, dw.max.y);
  return img;
}

bool same_bits(const ImageHalf& a, const ImageHalf& b) {
  return a.width == b.width && a.height == b.height && a.rgba == b.rgba;
}

class ThreadCount : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    saved_ = Imf::globalThreadCount();
    Imf::setGlobalThreadCount(GetParam());
  }
  void TearDown() override { Imf::setGlobalThreadCount(saved_); }
  int saved_ = 0;
};

// hdrd writes half pixels, OpenEXR reads them back bit for bit, and hdrd's half read gives
// the same bits again: for every lossless compression and with OpenEXR's pool at 0-4 threads.
TEST_P(ThreadCount, HalfPixelsRoundTripBitExactly) {
  TempDir tmp;
  const ImageHalf img = half_pattern(700, 333, true);  // 333 lines: 21 ZIP, 11 PIZ chunks
  for (const char* comp : {"none", "rle", "zips", "zip", "piz"}) {
    ExrWriteOptions opt;
    opt.compression = comp;
    const auto path = tmp / (std::string(comp) + ".exr");
    ASSERT_TRUE(write_exr(path, img, opt).ok()) << comp;
    EXPECT_TRUE(same_bits(openexr_read_half(path), img)) << comp;
    const auto back = read_exr(path, {.half_pixels = true});
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_TRUE(back->holds_half());
    EXPECT_TRUE(back->image.rgba.empty());
    EXPECT_EQ(back->width(), 700);
    EXPECT_TRUE(same_bits(back->half, img)) << comp;
  }
}

INSTANTIATE_TEST_SUITE_P(ExrHalf, ThreadCount, ::testing::Values(0, 1, 2, 4),
                         [](const auto& info) { return "threads" + std::to_string(info.param); });

// The float read of a half file is exactly the half read widened (OpenEXR converts on the way).
TEST(ExrHalf, HalfAndFloatReadsAgree) {
  HDRD_REQUIRE_FIXTURE(desk, "fixtures/exr/Desk.exr");
  for (const fs::path& path : {desk, *testing::fixture("fixtures/exr/MtTamWest.exr")}) {
    const auto f = read_exr(path), h = read_exr(path, {.half_pixels = true});
    ASSERT_TRUE(f.ok() && h.ok());
    ASSERT_TRUE(h->holds_half()) << path;
    ASSERT_EQ(h->half.rgba.size(), f->image.rgba.size());
    for (std::size_t i = 0; i < f->image.rgba.size(); ++i) {
      half v;
      v.setBits(h->half.rgba[i]);
      const float fv = v;
      ASSERT_TRUE(fv == f->image.rgba[i] || (std::isnan(fv) && std::isnan(f->image.rgba[i]))) << path << " " << i;
    }
    EXPECT_EQ(h->warnings, f->warnings);
    EXPECT_EQ(h->compression, f->compression);
  }
}

// Files with a float channel, one channel, missing channels or luminance/chroma: float
// channels stay float; the others follow the same rules as the float read.
TEST(ExrHalf, ChannelRulesHoldForHalfReads) {
  TempDir tmp;
  const int w = 40, h = 20;
  const auto write = [&](const fs::path& p, std::vector<std::pair<std::string, Imf::PixelType>> channels) {
    Imf::Header hd(w, h);
    Imf::FrameBuffer fb;
    std::vector<std::vector<float>> floats;  // OpenEXR writes each channel from its own type
    std::vector<std::vector<half>> halves;
    floats.reserve(channels.size());
    halves.reserve(channels.size());
    for (auto& [name, type] : channels) {
      hd.channels().insert(name, Imf::Channel(type));
      std::vector<float> v(static_cast<std::size_t>(w) * h);
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = 0.01f * static_cast<float>(i % 97) + static_cast<float>(name.size());
      if (type == Imf::FLOAT) {
        floats.push_back(std::move(v));
        fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(floats.back().data()), 4, 4 * w));
      } else {
        halves.emplace_back(v.begin(), v.end());
        fb.insert(name, Imf::Slice(Imf::HALF, reinterpret_cast<char*>(halves.back().data()), 2, 2 * w));
      }
    }
    Imf::OutputFile out(p.c_str(), hd);
    out.setFrameBuffer(fb);
    out.writePixels(h);
  };
  write(tmp / "mixed.exr", {{"R", Imf::HALF}, {"G", Imf::FLOAT}, {"B", Imf::HALF}});
  const auto mixed = read_exr(tmp / "mixed.exr", {.half_pixels = true});
  ASSERT_TRUE(mixed.ok());
  EXPECT_FALSE(mixed->holds_half());  // a float channel would lose precision in half
  EXPECT_EQ(mixed->image.rgba.size(), static_cast<std::size_t>(w) * h * 4);

  write(tmp / "grey.exr", {{"Z", Imf::HALF}});
  write(tmp / "rg.exr", {{"R", Imf::HALF}, {"G", Imf::HALF}});
  for (const char* name : {"grey.exr", "rg.exr"}) {
    const auto hf = read_exr(tmp / name, {.half_pixels = true}), fl = read_exr(tmp / name);
    ASSERT_TRUE(hf.ok() && fl.ok()) << name;
    ASSERT_TRUE(hf->holds_half()) << name;
    EXPECT_EQ(hf->warnings, fl->warnings);
    for (std::size_t i = 0; i < fl->image.rgba.size(); ++i) {
      half v;
      v.setBits(hf->half.rgba[i]);
      ASSERT_EQ(static_cast<float>(v), fl->image.rgba[i]) << name << " sample " << i;  // grey replicated, B = 0, A = 1
    }
  }

  std::vector<Imf::Rgba> src(static_cast<std::size_t>(w) * h);
  for (std::size_t i = 0; i < src.size(); ++i) src[i] = Imf::Rgba(0.1f + 0.001f * i, 0.2f, 0.3f, 1.0f);
  {
    Imf::RgbaOutputFile out((tmp / "yc.exr").c_str(), w, h, Imf::WRITE_YC);
    out.setFrameBuffer(src.data(), 1, w);
    out.writePixels(h);
  }
  const auto yc = read_exr(tmp / "yc.exr", {.half_pixels = true}), ycf = read_exr(tmp / "yc.exr");
  ASSERT_TRUE(yc.ok() && ycf.ok());
  ASSERT_TRUE(yc->holds_half());
  for (std::size_t i = 0; i < ycf->image.rgba.size(); ++i) {
    half v;
    v.setBits(yc->half.rgba[i]);
    ASSERT_EQ(static_cast<float>(v), ycf->image.rgba[i]) << "luminance/chroma sample " << i;
  }
}

// to_half against Imath's conversion for every half value, its neighbours, the rounding
// midpoints between them, overflow, NaN, and a scale applied to RGB only, on several threads.
TEST(ExrHalf, ToHalfMatchesImathBitForBit) {
  std::vector<float> values;
  for (std::uint32_t b = 0; b < 65536; ++b) {
    half h;
    h.setBits(static_cast<std::uint16_t>(b));
    const float f = h;
    values.push_back(f);
    values.push_back(std::nextafter(f, std::numeric_limits<float>::infinity()));
    values.push_back(std::nextafter(f, -std::numeric_limits<float>::infinity()));
    half up;
    up.setBits(static_cast<std::uint16_t>(b + 1));
    if (std::isfinite(f) && std::isfinite(static_cast<float>(up))) values.push_back(0.5f * (f + static_cast<float>(up)));
  }
  for (float f : {65504.0f, 65519.0f, 65520.0f, 1e9f, -1e9f, std::numeric_limits<float>::quiet_NaN(), 1e-10f})
    values.push_back(f);
  while (values.size() % 4) values.push_back(0);
  Image img(static_cast<int>(values.size() / 4), 1);
  img.rgba = values;
  for (float scale : {1.0f, 1.0f / 203.0f}) {
    for (int threads : {1, 3}) {
      const ImageHalf out = to_half(img, scale, threads);
      ASSERT_EQ(out.rgba.size(), values.size());
      for (std::size_t i = 0; i < values.size(); ++i) {
        const float in = i % 4 == 3 ? values[i] : values[i] * scale;  // alpha is never scaled
        const half want(in);
        if (std::isnan(in)) {
          half got;
          got.setBits(out.rgba[i]);
          ASSERT_TRUE(got.isNan()) << i;
        } else {
          ASSERT_EQ(out.rgba[i], want.bits()) << "value " << values[i] << " scale " << scale;
        }
      }
    }
  }
}

TEST(ExrHalf, HalfWriterRejectsFloatChannelsAndBadBuffers) {
  ImageHalf img(4, 4);
  ExrWriteOptions opt;
  opt.half = false;
  auto r = encode_exr(img, opt);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "half");
  img.rgba.pop_back();
  r = encode_exr(img, ExrWriteOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "exr.write");
}

}  // namespace
}  // namespace hdrd::io

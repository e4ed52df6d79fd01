// The identity-LUT workflow (Selan, GPU Gems 2 ch. 24): export the sliced identity as a
// 16-bit PNG, "edit" it, import it back. Unedited, the round trip is the identity within
// 2/65535; a blur is detected; colour-only edits are not flagged.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <png.h>

#include <cmath>
#include <fstream>
#include <functional>

#include "encode/grade/lut.hpp"
#include "tests/testing/testing.hpp"

using namespace hdrd;
using namespace hdrd::lut;

namespace {

float max_diff(const Lut3D& a, const Lut3D& b) {
  float m = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) m = std::max(m, std::fabs(a.rgb[i] - b.rgb[i]));
  return m;
}

TEST(Strip, ExportImportIsIdentity) {
  hdrd::testing::TempDir dir;
  for (int size : {2, 17, 33, 65}) {
    const auto path = dir / fmt::format("s{}.png", size);
    ASSERT_TRUE(write_strip_png(identity_strip(size), path, "size=" + std::to_string(size)).ok());
    std::string text;
    std::vector<std::string> warnings;
    auto strip = read_strip_png(path, &text, &warnings);
    ASSERT_TRUE(strip.ok()) << strip.error().message;
    EXPECT_EQ(strip->size, size);
    EXPECT_EQ(text, "size=" + std::to_string(size));
    EXPECT_TRUE(warnings.empty());
    const Lut3D lut = lut_from_strip(*strip);
    EXPECT_LE(max_diff(lut, Lut3D::identity(size)), 2.0f / 65535) << size;
    EXPECT_FALSE(detect_spatial_edit(lut).suspected) << size;
  }
}

TEST(Strip, LayoutIsSlicesAlongBlue) {
  const Strip s = identity_strip(3);  // 9 x 3
  const auto px = [&](int x, int y, int c) { return s.rgb[(y * 9 + x) * 3 + c]; };
  EXPECT_EQ(px(4, 2, 0), 32768);  // r = 4 mod 3 = 1 -> 1/2
  EXPECT_EQ(px(4, 2, 1), 65535);  // g = row 2
  EXPECT_EQ(px(4, 2, 2), 32768);  // b = 4 div 3 = 1
  EXPECT_EQ(px(8, 0, 2), 65535);
}

// Edits applied to the strip as an image editor would.
Strip edit_colours(Strip s, const std::function<void(double*)>& f) {
  for (std::size_t i = 0; i < s.rgb.size(); i += 3) {
    double v[3] = {s.rgb[i] / 65535.0, s.rgb[i + 1] / 65535.0, s.rgb[i + 2] / 65535.0};
    f(v);
    for (int c = 0; c < 3; ++c) s.rgb[i + c] = std::uint16_t(std::lround(std::clamp(v[c], 0.0, 1.0) * 65535));
  }
  return s;
}

Strip box_blur(const Strip& s, int radius) {
  const int w = s.size * s.size, h = s.size;
  Strip out = s;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        int n = 0;
        for (int dy = -radius; dy <= radius; ++dy)
          for (int dx = -radius; dx <= radius; ++dx) {
            const int xx = std::clamp(x + dx, 0, w - 1), yy = std::clamp(y + dy, 0, h - 1);
            sum += s.rgb[(std::size_t(yy) * w + xx) * 3 + c];
            ++n;
          }
        out.rgb[(std::size_t(y) * w + x) * 3 + c] = std::uint16_t(std::lround(sum / n));
      }
  return out;
}

TEST(Strip, BlurIsDetected) {
  for (int size : {17, 33})
    for (int radius : {1, 2}) {
      const auto check = detect_spatial_edit(lut_from_strip(box_blur(identity_strip(size), radius)));
      EXPECT_TRUE(check.suspected) << size << " r" << radius << " pull " << check.pull_right << "/" << check.pull_left;
    }
  // A blur on top of a colour edit too.
  const Strip graded = edit_colours(identity_strip(33), [](double* v) { for (int c = 0; c < 3; ++c) v[c] = std::pow(v[c], 0.7); });
  EXPECT_TRUE(detect_spatial_edit(lut_from_strip(box_blur(graded, 1))).suspected);
}

TEST(Strip, ColourEditsAreNotFlagged) {
  const std::vector<std::pair<const char*, std::function<void(double*)>>> edits = {
      {"gamma", [](double* v) { for (int c = 0; c < 3; ++c) v[c] = std::pow(v[c], 0.8); }},
      {"saturation", [](double* v) {
         const double y = 0.2627 * v[0] + 0.678 * v[1] + 0.0593 * v[2];
         for (int c = 0; c < 3; ++c) v[c] = y + 1.4 * (v[c] - y);
       }},
      {"clip whites", [](double* v) { for (int c = 0; c < 3; ++c) v[c] = std::min(v[c] * 1.1, 0.95); }},
      {"lift and fade", [](double* v) { for (int c = 0; c < 3; ++c) v[c] = 0.05 + 0.9 * std::pow(v[c], 1.2); }},
      {"s-curve", [](double* v) { for (int c = 0; c < 3; ++c) v[c] = v[c] * v[c] * (3 - 2 * v[c]); }},
      {"channel swap", [](double* v) { std::swap(v[0], v[2]); }},
  };
  for (const auto& [name, f] : edits) {
    const auto check = detect_spatial_edit(lut_from_strip(edit_colours(identity_strip(33), f)));
    EXPECT_FALSE(check.suspected) << name << " pull " << check.pull_right << "/" << check.pull_left << " noise "
                                  << check.noise;
  }
}

void write_png8(const std::filesystem::path& p, int w, int h) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  img.width = w;
  img.height = h;
  img.format = PNG_FORMAT_RGB;
  std::vector<png_byte> px(std::size_t(w) * h * 3, 128);
  ASSERT_TRUE(png_image_write_to_file(&img, p.c_str(), 0, px.data(), 0, nullptr));
}

TEST(Strip, ReadErrorsAndWarnings) {
  hdrd::testing::TempDir dir;
  write_png8(dir / "eight.png", 81, 9);
  std::vector<std::string> warnings;
  auto s = read_strip_png(dir / "eight.png", nullptr, &warnings);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("8-bit"), std::string::npos);
  EXPECT_EQ(s->rgb[0], 128 * 257);

  write_png8(dir / "cropped.png", 80, 9);
  auto bad = read_strip_png(dir / "cropped.png", nullptr, nullptr);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, "strip.size");
  EXPECT_NE(bad.error().message.find("80x9 is not a LUT strip"), std::string::npos) << bad.error().message;

  std::ofstream(dir / "text.png") << "not a png";
  EXPECT_EQ(read_strip_png(dir / "text.png", nullptr, nullptr).error().code, "strip.format");
  EXPECT_EQ(read_strip_png(dir / "missing.png", nullptr, nullptr).error().code, "strip.io");
  EXPECT_EQ(write_strip_png(identity_strip(2), dir / "no/such/dir.png", "").error().code, "strip.io");
  Strip big;
  big.size = kMaxStripSize + 1;
  EXPECT_EQ(write_strip_png(big, dir / "big.png", "").error().code, "strip.size");
}

// The command line: export-identity, then import, gives the identity back within 2/65535
// and records the shaper; a blurred strip warns.
TEST(Strip, CommandLineRoundTrip) {
  const auto hdrd = hdrd::testing::hdrd_binary();
  if (!std::filesystem::exists(hdrd)) GTEST_SKIP() << "hdrd not built: " << hdrd;
  hdrd::testing::TempDir dir;
  const auto strip = dir / "strip.png", cube = dir / "look.cube";
  auto r = hdrd::testing::run_command(fmt::format("{} lut export-identity --size 17 --shaper log2 -o {} --json", hdrd.string(),
                                            strip.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"size\": 17"), std::string::npos) << r.out;
  r = hdrd::testing::run_command(fmt::format("{} lut import {} -o {} --json", hdrd.string(), strip.string(), cube.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"spatial_edit_suspected\": false"), std::string::npos) << r.out;
  auto c = read_cube(cube);
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->lut3d);
  EXPECT_LE(max_diff(*c->lut3d, Lut3D::identity(17)), 2.0f / 65535);
  EXPECT_EQ(shaper_from_comments(c->comments)->kind, grade::Shaper::log2);

  auto s = read_strip_png(strip, nullptr, nullptr);
  ASSERT_TRUE(s.ok());
  ASSERT_TRUE(write_strip_png(box_blur(*s, 1), dir / "blurred.png", "").ok());
  r = hdrd::testing::run_command(fmt::format("{} lut import {} -o {}", hdrd.string(), (dir / "blurred.png").string(),
                                       (dir / "b.cube").string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("blur"), std::string::npos) << r.err;
}

}  // namespace

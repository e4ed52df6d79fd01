// Golden images of the built-in scenes as regression guards. Each golden is the
// scene-referred frame (absolute cd/m2, 160x90, 4x MSAA) after a fixed encode: PQ
// (SMPTE ST 2084) of the luminance per channel, stored as round(E' * 65535) in a 16-bit
// RGB PNG. Frames are compared in 10-bit PQ code values with the tolerances of
// golden/tolerances.json. Regenerate with HDRD_UPDATE_GOLDENS=1 (then review the diff).
#include <gtest/gtest.h>
#include <png.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include <nlohmann/json.hpp>

#include "encode/colour/transfer.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

constexpr int kW = 160, kH = 90;

std::filesystem::path golden_dir() { return hdrd::testing::source_dir() / "tests/shading/golden"; }

std::vector<std::uint16_t> fixed_encode(const Image& img) {
  std::vector<std::uint16_t> out(img.pixel_count() * 3);
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double nits = std::clamp(double(img.rgba[i * 4 + c]), 0.0, 10000.0);
      out[i * 3 + c] = static_cast<std::uint16_t>(std::lround(transfer::pq_inverse_eotf(nits) * 65535.0));
    }
  return out;
}

bool write_png16(const std::filesystem::path& path, const std::vector<std::uint16_t>& rgb, int w, int h) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return false;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
    return false;
  }
  png_init_io(png, f);
  png_set_compression_level(png, 9);
  png_set_IHDR(png, info, w, h, 16, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  std::vector<png_byte> row(static_cast<std::size_t>(w) * 6);
  for (int y = 0; y < h; ++y) {
    for (int i = 0; i < w * 3; ++i) {  // PNG samples are big-endian
      const std::uint16_t v = rgb[static_cast<std::size_t>(y) * w * 3 + i];
      row[2 * i] = static_cast<png_byte>(v >> 8);
      row[2 * i + 1] = static_cast<png_byte>(v & 0xff);
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return std::fclose(f) == 0;
}

std::optional<std::vector<std::uint16_t>> read_png16(const std::filesystem::path& path, int w, int h) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return std::nullopt;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  std::vector<std::uint16_t> out;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    return std::nullopt;
  }
  png_init_io(png, f);
  png_read_info(png, info);
  if (png_get_image_width(png, info) != static_cast<png_uint_32>(w) || png_get_image_height(png, info) != static_cast<png_uint_32>(h) ||
      png_get_bit_depth(png, info) != 16 || png_get_color_type(png, info) != PNG_COLOR_TYPE_RGB) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    return std::nullopt;
  }
  std::vector<png_byte> row(static_cast<std::size_t>(w) * 6);
  for (int y = 0; y < h; ++y) {
    png_read_row(png, row.data(), nullptr);
    for (int i = 0; i < w * 3; ++i) out.push_back(static_cast<std::uint16_t>((row[2 * i] << 8) | row[2 * i + 1]));
  }
  png_destroy_read_struct(&png, &info, nullptr);
  std::fclose(f);
  return out;
}

class Golden : public ::testing::TestWithParam<std::string> {};

TEST_P(Golden, MatchesWithinTolerance) {
  HDRD_REQUIRE_RENDERER(renderer);
  const std::string scene = GetParam();
  RenderRequest q;
  q.scene = scene;
  q.width = kW;
  q.height = kH;
  q.samples = 4;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto encoded = fixed_encode(r->scene_nits);
  const auto path = golden_dir() / (scene + ".png");
  if (const char* update = std::getenv("HDRD_UPDATE_GOLDENS"); update && std::string(update) == "1") {
    ASSERT_TRUE(write_png16(path, encoded, kW, kH)) << path;
    GTEST_SKIP() << "wrote " << path;
  }
  const auto golden = read_png16(path, kW, kH);
  ASSERT_TRUE(golden.has_value()) << "missing or unreadable golden " << path << " (HDRD_UPDATE_GOLDENS=1 makes it)";
  const auto tol = nlohmann::json::parse(hdrd::testing::read_file(golden_dir() / "tolerances.json"));
  const auto& t = tol["scenes"].contains(scene) ? tol["scenes"][scene] : tol["default"];
  const int max_code_diff = t.at("max_code_diff").get<int>();
  const double max_fraction = t.at("max_fraction_over_2_codes").get<double>();
  int worst = 0;
  std::size_t over = 0;
  for (std::size_t i = 0; i < encoded.size(); ++i) {
    const int a = static_cast<int>(std::lround(encoded[i] / 65535.0 * 1023.0));
    const int b = static_cast<int>(std::lround((*golden)[i] / 65535.0 * 1023.0));
    worst = std::max(worst, std::abs(a - b));
    over += std::abs(a - b) > 2;
  }
  EXPECT_LE(worst, max_code_diff) << scene << " on " << r->gl_renderer;
  EXPECT_LE(double(over) / encoded.size(), max_fraction) << scene << ": " << over << " samples more than 2 codes off";
}

INSTANTIATE_TEST_SUITE_P(BuiltinScenes, Golden, ::testing::ValuesIn(builtin_scene_names()),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (auto& c : n) if (c == '-') c = '_';
                           return n;
                         });

}  // namespace
}  // namespace hdrd::shading

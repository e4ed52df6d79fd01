// The heatmap output through the CLI (hdrd encode/render --format ...,heatmap): the picture decodes, its
// legend is where heatmap_layout() says, a known luminance lands on the legend's colour
// for that luminance, and the file is listed in the --json output and the sidecar.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "patterns/plot.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::patterns {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 64, kHeight = 36;

// A float32 EXR of one relative value everywhere (1.0 = paper white).
void write_uniform_exr(const fs::path& p, float relative) {
  Image img(kWidth, kHeight);
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    img.rgba[i * 4] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = relative, img.rgba[i * 4 + 3] = 1;
  io::ExrWriteOptions o;
  o.half = false;
  ASSERT_TRUE(io::write_exr(p, img, o).ok());
}

struct Png {
  int width = 0, height = 0, channels = 3;
  std::vector<std::uint16_t> samples;  // 8-bit values, `channels` per pixel
  Rgb8 at(int x, int y) const {
    const std::size_t i = (static_cast<std::size_t>(y) * width + x) * channels;
    return {std::uint8_t(samples[i]), std::uint8_t(samples[i + 1]), std::uint8_t(samples[i + 2])};
  }
};

Png read_heatmap(const fs::path& p) {
  auto info = io::read_png_info(p);
  EXPECT_TRUE(info) << (info ? "" : info.error().message);
  if (!info) return {};
  EXPECT_EQ(info->bit_depth, 8);
  EXPECT_GE(info->channels, 3);
  Png png{info->width, info->height, info->channels, info->samples};
  EXPECT_EQ(png.samples.size(), static_cast<std::size_t>(png.width) * png.height * png.channels);
  return png;
}

int distance(Rgb8 a, Rgb8 b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

// The luminance the legend bar shows in the colour closest to `c`.
double legend_reading(const Png& png, const HeatmapLayout& l, Rgb8 c) {
  int best_row = l.legend_top, best = 1000;
  for (int y = l.legend_top; y <= l.legend_bottom; ++y) {
    const int d = distance(png.at(l.legend_x + l.legend_width / 2, y), c);
    if (d < best) best = d, best_row = y;
  }
  EXPECT_LE(best, 8) << "no legend colour near the picture's";
  return l.legend_nits(best_row);
}

void expect_legend(const Png& png, const HeatmapLayout& l) {
  ASSERT_GE(png.width, l.width);
  ASSERT_EQ(png.height, l.height);
  const int bar = l.legend_x + l.legend_width / 2;
  // The bar runs from white (10000 cd/m2) at the top to dark blue (0.01 cd/m2) at the bottom.
  EXPECT_EQ(png.at(bar, l.legend_row(10000)), heat_colour(10000));
  EXPECT_EQ(png.at(bar, l.legend_row(0.01)), heat_colour(0.01));
  EXPECT_LE(distance(png.at(bar, l.legend_row(100)), heat_colour(100)), 8);
  // Decade labels: dark text right of the bar, beside each of the seven ticks.
  for (int d = -2; d <= 4; ++d) {
    const int row = l.legend_row(std::pow(10.0, d));
    int ink = 0;
    for (int y = row - 4; y <= row + 4; ++y)
      for (int x = l.legend_x + l.legend_width + 6; x < std::min(png.width, l.legend_x + l.legend_width + 40); ++x)
        ink += png.at(x, y) == Rgb8{0, 0, 0};
    EXPECT_GT(ink, 5) << "no label at 1e" << d << " cd/m2";
  }
}

TEST(DebugHeatmapCli, EncodeWritesTheHeatmapWithALegendAndListsIt) {
  testing::TempDir dir;
  write_uniform_exr(dir / "white.exr", 1.0f);
  const fs::path out = dir / "white";
  // Relative 1.0 with the clip curve at 0 EV is paper white: 203 cd/m2 (PQ code 594).
  const auto r = testing::run_command(testing::hdrd_binary().string() + " encode " + (dir / "white.exr").string() +
                                      " -o " + out.string() +
                                      " --mode hdr10 --tonemap clip --format png,heatmap --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path heat = out.string() + ".heatmap.png";
  ASSERT_TRUE(fs::exists(heat));

  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["files"]["heatmap"], heat.string()) << j["files"];
  const auto side = nlohmann::json::parse(testing::read_file(out.string() + ".json"));
  EXPECT_EQ(side["files"]["heatmap"], "white.heatmap.png") << side["files"];
  EXPECT_EQ(side["files"]["png"], "white.png");

  const Png png = read_heatmap(heat);
  const HeatmapLayout l = heatmap_layout(kWidth, kHeight);
  expect_legend(png, l);
  const Rgb8 centre = png.at(l.image_x + kWidth / 2, l.image_y + kHeight / 2);
  EXPECT_LE(distance(centre, png.at(l.legend_x + l.legend_width / 2, l.legend_row(203))), 8);
  const double reading = legend_reading(png, l, centre);
  EXPECT_NEAR(std::log10(reading), std::log10(203.0), 0.04) << reading << " cd/m2";  // one legend row
  // Uniform frame: every picture pixel has that colour.
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) ASSERT_EQ(png.at(l.image_x + x, l.image_y + y), centre) << x << "," << y;
}

// Two luminances in one frame read back apart on the legend: 203 cd/m2 and 10 x lower.
TEST(DebugHeatmapCli, EncodeSdrReadsBackBelowPaperWhite) {
  testing::TempDir dir;
  write_uniform_exr(dir / "grey.exr", 0.18f);
  const fs::path out = dir / "grey";
  const auto r = testing::run_command(testing::hdrd_binary().string() + " encode " + (dir / "grey.exr").string() +
                                      " -o " + out.string() + " --mode sdr --tonemap clip --format png,heatmap -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Png png = read_heatmap(out.string() + ".heatmap.png");
  const HeatmapLayout l = heatmap_layout(kWidth, kHeight);
  expect_legend(png, l);
  // SDR at its defaults: peak = paper white = 100 cd/m2, so relative 0.18 is 18 cd/m2
  // (8-bit sRGB code 118 decodes to 18.1).
  const double reading = legend_reading(png, l, png.at(l.image_x + 5, l.image_y + 5));
  EXPECT_NEAR(std::log10(reading), std::log10(18.0), 0.04) << reading << " cd/m2";
  // The default dump has no heatmap and the sidecar does not list one.
  const auto plain = testing::run_command(testing::hdrd_binary().string() + " encode " + (dir / "grey.exr").string() +
                                          " -o " + (dir / "plain").string() + " --mode sdr -q");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_FALSE(fs::exists(dir / "plain.heatmap.png"));
  EXPECT_FALSE(nlohmann::json::parse(testing::read_file(dir / "plain.json"))["files"].contains("heatmap"));
}

TEST(DebugHeatmapCli, UnknownFormatIsOneLineAndWritesNothing) {
  testing::TempDir dir;
  write_uniform_exr(dir / "in.exr", 1.0f);
  const auto r = testing::run_command(testing::hdrd_binary().string() + " encode " + (dir / "in.exr").string() +
                                      " -o " + (dir / "out").string() + " --format heatmap,histogram");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--format"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'histogram'"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out.json"));
  EXPECT_FALSE(fs::exists(dir / "out.heatmap.png"));
}

TEST(DebugHeatmapCli, RenderWritesTheHeatmap) {
  testing::TempDir dir;
  const fs::path out = dir / "furnace";
  const auto r = testing::run_command(testing::hdrd_binary().string() + " render --scene furnace -o " + out.string() +
                                      " --width 64 --height 36 --samples 1 --format png,heatmap --json -q");
  if (r.exit_code != 0 && (r.err.find("EGL") != std::string::npos || r.err.find("GL context") != std::string::npos ||
                           r.err.find("OSMesa") != std::string::npos))
    GTEST_SKIP() << "no GL context: " << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["files"]["heatmap"], out.string() + ".heatmap.png");
  const auto side = nlohmann::json::parse(testing::read_file(out.string() + ".json"));
  EXPECT_EQ(side["files"]["heatmap"], "furnace.heatmap.png");
  EXPECT_FALSE(side["files"].contains("scene-exr")) << "not asked for";
  const Png png = read_heatmap(out.string() + ".heatmap.png");
  expect_legend(png, heatmap_layout(64, 36));
}

}  // namespace
}  // namespace hdrd::patterns

// Pictures: the plots and sheets decode (PNG through io::read_png_info, SVG as well-formed
// XML with the expected elements), and the physics behind them matches published values.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <vector>

#include "encode/io/io.hpp"
#include "encode/tone/tonemap.hpp"
#include "patterns/plot.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::patterns {
namespace {

// A small well-formedness check: every tag closes in order, attributes are quoted.
bool well_formed_xml(const std::string& s, std::string* why) {
  std::vector<std::string> stack;
  std::size_t i = 0;
  while ((i = s.find('<', i)) != std::string::npos) {
    const std::size_t end = s.find('>', i);
    if (end == std::string::npos) return *why = "unterminated tag", false;
    const std::string tag = s.substr(i + 1, end - i - 1);
    i = end + 1;
    if (tag.empty()) return *why = "empty tag", false;
    if (tag[0] == '?' || tag[0] == '!') continue;
    if (tag[0] == '/') {
      if (stack.empty() || stack.back() != tag.substr(1)) return *why = "mismatched </" + tag.substr(1) + ">", false;
      stack.pop_back();
      continue;
    }
    if (std::count(tag.begin(), tag.end(), '"') % 2) return *why = "unbalanced quotes in <" + tag + ">", false;
    if (tag.back() == '/') continue;
    stack.push_back(tag.substr(0, tag.find_first_of(" \n")));
  }
  if (!stack.empty()) return *why = "unclosed <" + stack.back() + ">", false;
  return true;
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t i = 0; (i = s.find(what, i)) != std::string::npos; i += what.size()) ++n;
  return n;
}

TEST(CurvesPlot, SvgIsWellFormedWithOneSeriesPerCurve) {
  const Plot p = tone_curves_plot(1000);
  const std::string svg = render_svg(p);
  std::string why;
  EXPECT_TRUE(well_formed_xml(svg, &why)) << why;
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_EQ(count(svg, "<polyline class=\"series\""), p.series.size());
  EXPECT_GE(p.series.size(), 3u);
  for (const auto& info : tonemap::curves()) EXPECT_NE(svg.find(">" + std::string(info.name) + "<"), std::string::npos) << info.name;
  // Every curve reaches at most the peak; clip reaches it exactly at x = 1000/203.
  for (const auto& s : p.series)
    for (const auto& pt : s.points) EXPECT_LE(pt[1], 1000 * (1 + 1e-6)) << s.name;
}

TEST(CurvesPlot, PngDecodesWithAxesAndColouredLines) {
  const Canvas8 c = render_raster(tone_curves_plot(1000));
  auto png = c.png();
  ASSERT_TRUE(png);
  auto info = io::read_png_info_memory(*png);
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->width, 960);
  EXPECT_EQ(info->height, 600);
  EXPECT_EQ(info->bit_depth, 8);
  int coloured = 0, black = 0;
  for (std::size_t i = 0; i + 2 < info->samples.size(); i += 3) {
    const int r = info->samples[i], g = info->samples[i + 1], b = info->samples[i + 2];
    coloured += (std::max({r, g, b}) - std::min({r, g, b})) > 60;
    black += r + g + b == 0;
  }
  EXPECT_GT(coloured, 2000);  // curve lines
  EXPECT_GT(black, 2000);     // frame, ticks, text
}

// Issue 29 item 6: a dashed series drawn from many short segments (a curve's 300 points)
// was solid in the PNG, the dash restarting at every segment. Along a dashed horizontal line
// the raster must be on about half the time, in runs about the dash length long.
TEST(CurvesPlot, RasterDashesRunAcrossShortSegments) {
  Plot p;
  p.width = 400, p.height = 200;
  p.x_min = 0, p.x_max = 1, p.y_min = 0, p.y_max = 1;
  Series s{"dashed", {214, 39, 40}, {}, 8};
  for (int k = 0; k <= 300; ++k) s.points.push_back({k / 300.0, 0.5});  // ~1 px per segment
  p.series.push_back(s);
  const Canvas8 c = render_raster(p);
  // The row the line is on: the one with the most of its colour.
  int best_row = 0, best = -1;
  for (int y = 0; y < c.height; ++y) {
    int n = 0;
    for (int x = 100; x < 300; ++x) n += c.get(x, y) == s.colour;
    if (n > best) best = n, best_row = y;
  }
  int on = 0, runs = 0;
  bool prev = false;
  for (int x = 100; x < 300; ++x) {
    const bool cur = c.get(x, best_row) == s.colour;
    on += cur;
    runs += cur && !prev;
    prev = cur;
  }
  EXPECT_GT(on, 200 * 0.35) << "the line is missing";
  EXPECT_LT(on, 200 * 0.65) << "the dashed line is drawn solid";
  EXPECT_GE(runs, 200 / 16 - 2);  // one dash per 16 px
}

// No two curves of the plot share a line style, so none can be mistaken for another (before,
// aces-ocio-sdr-video had pq-shoulder's colour, its dashes lost in the PNG).
TEST(CurvesPlot, EveryCurveHasItsOwnStyle) {
  const Plot p = tone_curves_plot(1000);
  ASSERT_EQ(p.series.size(), tonemap::curves().size());
  for (std::size_t i = 0; i < p.series.size(); ++i)
    for (std::size_t j = i + 1; j < p.series.size(); ++j)
      EXPECT_FALSE(p.series[i].colour == p.series[j].colour && p.series[i].dash == p.series[j].dash)
          << p.series[i].name << " and " << p.series[j].name;
  // The styles are as distinct as the palette allows: 3 x kPlotColours before a repeat.
  const std::size_t styles = 3 * static_cast<std::size_t>(kPlotColours);
  for (std::size_t i = 0; i < styles; ++i)
    for (std::size_t j = i + 1; j < styles; ++j) {
      const auto a = series_style(i), b = series_style(j);
      EXPECT_FALSE(a.colour == b.colour && a.dash == b.dash) << i << " " << j;
    }
}

// Fresnel equations against published values: glass n = 1.5 reflects 4 % at normal
// incidence and 5.0 % (Rs 9.2 %, Rp 0.85 %) at 45 degrees; every conductor reaches 1 at grazing.
TEST(Fresnel, ConductorEquationsMatchPublishedValues) {
  EXPECT_NEAR(fresnel_conductor(1.0, 1.5, 0), 0.04, 1e-9);
  EXPECT_NEAR(fresnel_conductor(std::cos(M_PI / 4), 1.5, 0), 0.0503, 2e-4);
  // A conductor (gold near 550 nm, n = 0.42, k = 2.35) at normal incidence equals the
  // normal-incidence formula ((n-1)^2 + k^2) / ((n+1)^2 + k^2) (RTR4 §9.5).
  const double n = 0.42, k = 2.35;
  EXPECT_NEAR(fresnel_conductor(1.0, n, k), ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k), 1e-9);
  EXPECT_NEAR(fresnel_conductor(1e-6, n, k), 1.0, 1e-4);
}

TEST(Fresnel, PlotHasSchlickForEveryTable92MetalAndExactWhereKnown) {
  const Plot p = fresnel_plot();
  int exact = 0, schlick = 0;
  for (const auto& s : p.series) {
    (s.dash > 0 ? exact : schlick)++;
    EXPECT_NEAR(s.points.back()[1], 1.0, 1e-3) << s.name;  // F(90 degrees) = 1
    for (std::size_t i = 1; i < s.points.size(); ++i) EXPECT_GE(s.points[i][1], s.points[i - 1][1] - 0.02) << s.name;
  }
  EXPECT_GE(schlick, 10);
  EXPECT_GE(exact, 2);
  std::string why;
  EXPECT_TRUE(well_formed_xml(render_svg(p), &why)) << why;
}

TEST(Heatmap, ColoursFollowTheLegendAndThePngDecodes) {
  EXPECT_GT(heat_colour(0.1)[2], heat_colour(0.1)[0]);     // blue at 0.1 cd/m2
  EXPECT_GT(heat_colour(1000)[0], heat_colour(1000)[2]);   // red at 1000 cd/m2
  EXPECT_EQ(heat_colour(10000), (Rgb8{255, 255, 255}));    // white at the PQ maximum
  Image lum(200, 100);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 200; ++x) lum.px(x, y)[0] = float(std::pow(10.0, -2 + 6.0 * x / 199));
  auto png = heatmap(lum, "TEST").png();
  ASSERT_TRUE(png);
  auto info = io::read_png_info_memory(*png);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->width, 310);
}

TEST(ContactSheetCli, OneTilePerCurveInADecodablePng) {
  HDRD_REQUIRE_FIXTURE(exr, "fixtures/exr/GrayRampsHorizontal.exr");
  testing::TempDir dir;
  const auto out = (dir / "sheet.png").string();
  auto r = testing::run_command(testing::hdrd_binary().string() + " contact-sheet " + exr.string() + " -o " + out +
                                " --tile-width 100 --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto info = io::read_png_info(out);
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->bit_depth, 8);
  EXPECT_GT(info->width, 4 * 64);
}

TEST(PlotCli, CurvesSvgAndPngAndHeatmap) {
  testing::TempDir dir;
  const std::string bin = testing::hdrd_binary().string();
  auto svg = testing::run_command(bin + " plot curves --peak 600 -o " + (dir / "c.svg").string());
  ASSERT_EQ(svg.exit_code, 0) << svg.err;
  std::string why;
  EXPECT_TRUE(well_formed_xml(testing::read_file(dir / "c.svg"), &why)) << why;
  auto png = testing::run_command(bin + " plot fresnel -o " + (dir / "f.png").string());
  ASSERT_EQ(png.exit_code, 0) << png.err;
  EXPECT_TRUE(io::read_png_info(dir / "f.png"));
  HDRD_REQUIRE_FIXTURE(exr, "fixtures/exr/GrayRampsHorizontal.exr");
  // The heatmap is an output of the frame job (hdrd encode --format heatmap), not a plot.
  auto heat = testing::run_command(bin + " encode " + exr.string() + " --mode hdr10 --format heatmap -o " + (dir / "h").string());
  ASSERT_EQ(heat.exit_code, 0) << heat.err;
  EXPECT_TRUE(io::read_png_info(dir / "h.heatmap.png"));
}

}  // namespace
}  // namespace hdrd::patterns

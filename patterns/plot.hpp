// Pictures: line plots rendered both as SVG text and as an 8-bit sRGB raster (with the
// built-in font), false-colour luminance heatmaps and contact sheets. No plotting or
// font library: a plot is data (series of points) and two small renderers.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "encode/frame.hpp"
#include "encode/image.hpp"
#include "encode/io/io.hpp"
#include "encode/result.hpp"

namespace hdrd::patterns {

using Rgb8 = std::array<std::uint8_t, 3>;

// An sRGB 8-bit raster; written as an SDR PNG through io::encode_png.
struct Canvas8 {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  Canvas8(int w, int h, Rgb8 background = {255, 255, 255});
  void set(int x, int y, Rgb8 c);
  Rgb8 get(int x, int y) const;
  void fill(int x0, int y0, int x1, int y1, Rgb8 c);
  // dash > 0: dash pixels on, dash off, measured along the line from *dash_phase (pixels of
  // line drawn before: a polyline passes it from segment to segment, so a dash pattern runs
  // on across segments shorter than a dash); advanced by this segment's length.
  void line(double x0, double y0, double x1, double y1, Rgb8 c, int thickness = 1, int dash = 0,
            double* dash_phase = nullptr);
  void text(const std::string& s, int x, int y, Rgb8 c, int scale = 1);
  EncodedFrame to_frame() const;  // 8-bit sRGB XRGB8888
  Result<std::vector<std::uint8_t>> png() const;
};

struct Series {
  std::string name;
  Rgb8 colour;
  std::vector<std::array<double, 2>> points;
  int dash = 0;  // 0: solid; else the on/off length in pixels (SVG stroke-dasharray, raster alike)
};

// The line style of a plot's series i: a distinct colour for each of the first
// kPlotColours, then the same colours again with longer and shorter dashes, so that no two
// of up to 3 x kPlotColours series share colour and dash.
inline constexpr int kPlotColours = 14;
struct SeriesStyle {
  Rgb8 colour;
  int dash;
};
SeriesStyle series_style(std::size_t i);

struct Plot {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;
  std::vector<double> x_ticks, y_ticks;
  std::vector<Series> series;
  int width = 960, height = 600;
};

std::string render_svg(const Plot& plot);
Canvas8 render_raster(const Plot& plot);

// Every registered tone curve: display cd/m2 against relative scene value, log-log, for a
// display of the given peak (paper white 203 cd/m2 unless given).
Plot tone_curves_plot(double peak_nits, double paper_white_nits = 203, double black_nits = 0.005);

// F against sin(theta) for the RTR4 table 9.2 metals: Schlick (eq. 9.16) solid, the exact
// conductor Fresnel equations dashed where n and k are known (table 9.4 metals).
Plot fresnel_plot();
// Unpolarised Fresnel reflectance of a conductor n + ik from air (Born & Wolf; pbrt-v3 FrConductor).
double fresnel_conductor(double cos_theta, double n, double k);

// False-colour map of luminance (cd/m2, log scale 0.01..10000) with a legend in cd/m2.
Rgb8 heat_colour(double nits);
Canvas8 heatmap(const Image& luminance_nits_rgba, const std::string& title);

// Where heatmap() puts the picture and its legend for a luminance image of the given size:
// the picture at the top left under the title, the legend bar (10000 cd/m2 at the top to
// 0.01 cd/m2 at the bottom, labelled every decade) to its right.
struct HeatmapLayout {
  int image_x = 0, image_y = 0;
  int legend_x = 0, legend_width = 0;
  int legend_top = 0, legend_bottom = 0;  // the rows of 10000 and 0.01 cd/m2
  int width = 0, height = 0;              // the canvas, before widening for a long title
  int legend_row(double nits) const;      // the bar row that shows `nits`
  double legend_nits(int row) const;      // the luminance the bar shows at `row`
};
HeatmapLayout heatmap_layout(int image_width, int image_height);

// Luminance (cd/m2) of display light in the given primaries, into R=G=B of a new image.
Image luminance_image(const Image& display_nits, const color::Primaries& primaries);

// The luminance a display shows for each pixel, decoded from the frame's own codes
// (patterns/decode.hpp: the mode's EOTF, in the container primaries): what the encode
// produced after quantisation, whichever path (CPU or GPU) made the frame.
Image decoded_luminance(const EncodedFrame& frame);

// The heatmap of an encoded frame: decoded_luminance() under a title naming the mode and peak.
Canvas8 frame_heatmap(const EncodedFrame& frame);

struct SheetTile {
  std::string label;
  const EncodedFrame* frame = nullptr;  // 8-bit SDR; null: an error tile
  std::string error;
};
// Tiles in a grid, each labelled under the image.
Canvas8 contact_sheet(const std::vector<SheetTile>& tiles, const std::string& title, int columns = 4);

// Box-filtered downscale to at most `max_width` pixels wide.
Image downscale(const Image& img, int max_width);

}  // namespace hdrd::patterns

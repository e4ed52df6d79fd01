#include "patterns/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "encode/tone/tonemap.hpp"
#include "encode/colour/transfer.hpp"
#include "patterns/decode.hpp"
#include "patterns/font.hpp"
#include "shading/materials.hpp"

namespace hdrd::patterns {

// ---- Canvas ------------------------------------------------------------------------------
Canvas8::Canvas8(int w, int h, Rgb8 bg) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3) {
  for (std::size_t i = 0; i < rgb.size(); i += 3) rgb[i] = bg[0], rgb[i + 1] = bg[1], rgb[i + 2] = bg[2];
}

void Canvas8::set(int x, int y, Rgb8 c) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  std::memcpy(&rgb[(static_cast<std::size_t>(y) * width + x) * 3], c.data(), 3);
}

Rgb8 Canvas8::get(int x, int y) const {
  const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 3;
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

void Canvas8::fill(int x0, int y0, int x1, int y1, Rgb8 c) {
  for (int y = std::max(0, y0); y < std::min(height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(width, x1); ++x) set(x, y, c);
}

// Steps along the line one pixel at a time (DDA), stamping a square of `thickness`.
void Canvas8::line(double x0, double y0, double x1, double y1, Rgb8 c, int thickness, int dash, double* dash_phase) {
  const double dx = x1 - x0, dy = y1 - y0;
  const int n = std::max(1, static_cast<int>(std::ceil(std::max(std::abs(dx), std::abs(dy)))));
  const double step = std::hypot(dx, dy) / n, start = dash_phase ? *dash_phase : 0;
  if (dash_phase) *dash_phase = start + step * n;
  for (int i = 0; i <= n; ++i) {
    if (dash > 0 && static_cast<long long>(std::floor((start + step * i) / dash)) % 2 == 1) continue;
    const int x = static_cast<int>(std::lround(x0 + dx * i / n)), y = static_cast<int>(std::lround(y0 + dy * i / n));
    fill(x - thickness / 2, y - thickness / 2, x - thickness / 2 + thickness, y - thickness / 2 + thickness, c);
  }
}

void Canvas8::text(const std::string& s, int x, int y, Rgb8 c, int scale) {
  draw_text(s, x, y, scale, [&](int px, int py) { set(px, py, c); });
}

EncodedFrame Canvas8::to_frame() const {
  EncodedFrame f;
  f.target = default_target(Mode::sdr);
  f.target.bits = 8;
  f.width = width, f.height = height;
  f.drm_fourcc = kDrmFormatXrgb8888;
  f.stride_bytes = static_cast<std::size_t>(width) * 4;
  f.data.resize(f.stride_bytes * height);
  for (std::size_t i = 0; i < static_cast<std::size_t>(width) * height; ++i) {
    f.data[i * 4] = rgb[i * 3 + 2], f.data[i * 4 + 1] = rgb[i * 3 + 1], f.data[i * 4 + 2] = rgb[i * 3];
    f.data[i * 4 + 3] = 255;
  }
  f.mastering = f.target.mastering();
  return f;
}

Result<std::vector<std::uint8_t>> Canvas8::png() const { return io::encode_png(to_frame()); }

// ---- Plot rendering ------------------------------------------------------------------------
namespace {

struct Frame {  // plot area in pixels
  double left = 80, right, top = 50, bottom;
};

Frame plot_frame(const Plot& p, int legend_rows) {
  Frame f;
  f.right = p.width - 20;
  f.bottom = p.height - 50 - 14.0 * ((legend_rows + 3) / 4);
  return f;
}

double map_x(const Plot& p, const Frame& f, double x) {
  const double t = p.log_x ? (std::log10(x) - std::log10(p.x_min)) / (std::log10(p.x_max) - std::log10(p.x_min))
                           : (x - p.x_min) / (p.x_max - p.x_min);
  return f.left + t * (f.right - f.left);
}
double map_y(const Plot& p, const Frame& f, double y) {
  const double t = p.log_y ? (std::log10(y) - std::log10(p.y_min)) / (std::log10(p.y_max) - std::log10(p.y_min))
                           : (y - p.y_min) / (p.y_max - p.y_min);
  return f.bottom - t * (f.bottom - f.top);
}
bool inside(const Plot& p, double x, double y) {
  return std::isfinite(x) && std::isfinite(y) && (!p.log_x || x > 0) && (!p.log_y || y > 0) && x >= p.x_min * 0.999 &&
         x <= p.x_max * 1.001 && y >= p.y_min - 1e-12 && y <= p.y_max * 1.001;
}
std::string tick_label(double v) {
  if (v == 0) return "0";
  if (std::abs(v) >= 1) return fmt::format("{:g}", v);
  return fmt::format("{:g}", v);
}
std::string dash_attribute(int dash) {
  return dash > 0 ? fmt::format(" stroke-dasharray=\"{},{}\"", dash, dash) : std::string();
}
std::string hex(Rgb8 c) { return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]); }
std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '&') o += "&amp;";
    else if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}
// Legend entry i sits in a 4-column grid under the x axis label.
std::pair<double, double> legend_pos(const Plot& p, const Frame& f, std::size_t i) {
  return {f.left + (i % 4) * (f.right - f.left) / 4.0, f.bottom + 40 + 14.0 * (i / 4)};
}

}  // namespace

std::string render_svg(const Plot& p) {
  const Frame f = plot_frame(p, static_cast<int>(p.series.size()));
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
      "viewBox=\"0 0 {} {}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" "
      "fill=\"white\"/>\n<title>{}</title>\n",
      p.width, p.height, p.width, p.height, xml_escape(p.title));
  s += fmt::format("<text x=\"{}\" y=\"30\" font-size=\"15\" text-anchor=\"middle\">{}</text>\n", p.width / 2,
                   xml_escape(p.title));
  for (double t : p.x_ticks) {
    const double x = map_x(p, f, t);
    s += fmt::format("<line x1=\"{:.1f}\" y1=\"{}\" x2=\"{:.1f}\" y2=\"{}\" stroke=\"#ddd\"/>\n", x, f.top, x, f.bottom);
    s += fmt::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", x, f.bottom + 14, tick_label(t));
  }
  for (double t : p.y_ticks) {
    const double y = map_y(p, f, t);
    s += fmt::format("<line x1=\"{}\" y1=\"{:.1f}\" x2=\"{}\" y2=\"{:.1f}\" stroke=\"#ddd\"/>\n", f.left, y, f.right, y);
    s += fmt::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n", f.left - 4, y + 4, tick_label(t));
  }
  s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", f.left, f.top,
                   f.right - f.left, f.bottom - f.top);
  s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (f.left + f.right) / 2, f.bottom + 28,
                   xml_escape(p.x_label));
  s += fmt::format("<text x=\"14\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {})\">{}</text>\n",
                   (f.top + f.bottom) / 2, (f.top + f.bottom) / 2, xml_escape(p.y_label));
  for (std::size_t i = 0; i < p.series.size(); ++i) {
    const Series& se = p.series[i];
    std::string pts;
    for (const auto& [x, y] : se.points)
      if (inside(p, x, y)) pts += fmt::format("{:.1f},{:.1f} ", map_x(p, f, x), map_y(p, f, y));
    s += fmt::format("<polyline class=\"series\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.6\"{} points=\"{}\">"
                     "<title>{}</title></polyline>\n",
                     hex(se.colour), dash_attribute(se.dash), pts, xml_escape(se.name));
    const auto [lx, ly] = legend_pos(p, f, i);
    s += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"2\"{}/>"
                     "<text class=\"legend\" x=\"{}\" y=\"{}\">{}</text>\n",
                     lx, ly - 4, lx + 18, ly - 4, hex(se.colour), dash_attribute(se.dash), lx + 22,
                     ly, xml_escape(se.name));
  }
  return s + "</svg>\n";
}

Canvas8 render_raster(const Plot& p) {
  const Frame f = plot_frame(p, static_cast<int>(p.series.size()));
  Canvas8 c(p.width, p.height);
  const Rgb8 black{0, 0, 0}, grid{221, 221, 221};
  c.text(p.title, p.width / 2 - text_width(p.title, 2) / 2, 14, black, 2);
  for (double t : p.x_ticks) {
    const double x = map_x(p, f, t);
    c.line(x, f.top, x, f.bottom, grid);
    c.text(tick_label(t), int(x) - text_width(tick_label(t)) / 2, int(f.bottom) + 6, black);
  }
  for (double t : p.y_ticks) {
    const double y = map_y(p, f, t);
    c.line(f.left, y, f.right, y, grid);
    c.text(tick_label(t), int(f.left) - 4 - text_width(tick_label(t)), int(y) - 3, black);
  }
  c.line(f.left, f.top, f.right, f.top, black), c.line(f.left, f.bottom, f.right, f.bottom, black);
  c.line(f.left, f.top, f.left, f.bottom, black), c.line(f.right, f.top, f.right, f.bottom, black);
  c.text(p.x_label, int((f.left + f.right) / 2) - text_width(p.x_label) / 2, int(f.bottom) + 20, black);
  c.text(p.y_label, 4, int(f.top) - 14, black);
  for (std::size_t i = 0; i < p.series.size(); ++i) {
    const Series& se = p.series[i];
    bool have = false;
    double px = 0, py = 0, phase = 0;
    for (const auto& [x, y] : se.points) {
      if (!inside(p, x, y)) { have = false; continue; }
      const double qx = map_x(p, f, x), qy = map_y(p, f, y);
      if (have) c.line(px, py, qx, qy, se.colour, 2, se.dash, &phase);
      px = qx, py = qy, have = true;
    }
    const auto [lx, ly] = legend_pos(p, f, i);
    // The legend's sample is long enough to show two dashes of the longest pattern.
    c.line(lx, ly - 3, lx + 18, ly - 3, se.colour, 2, std::min(se.dash, 5));
    c.text(se.name, int(lx) + 22, int(ly) - 6, black);
  }
  return c;
}

// ---- Tone curves and Fresnel -------------------------------------------------------------
namespace {
// Tableau 10, black and three dark tones of d3's category20b: apart on white and from one
// another (Tableau 20's light tones, used before, are too pale for 2-pixel lines).
constexpr Rgb8 kPalette[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44},  {214, 39, 40},  {148, 103, 189},
                             {140, 86, 75},  {227, 119, 194}, {127, 127, 127}, {188, 189, 34}, {23, 190, 207},
                             {0, 0, 0},      {57, 59, 121},   {132, 60, 57},  {99, 121, 57}};
static_assert(std::size(kPalette) == kPlotColours);
constexpr int kDashes[] = {0, 8, 3};  // solid, long dashes, short dashes
Rgb8 palette(std::size_t i) { return kPalette[i % kPlotColours]; }
}  // namespace

SeriesStyle series_style(std::size_t i) {
  return {palette(i), kDashes[(i / kPlotColours) % std::size(kDashes)]};
}

Plot tone_curves_plot(double peak, double pw, double black) {
  Plot p;
  p.title = fmt::format("Tone curves for a {:g} cd/m2 display (paper white {:g} cd/m2)", peak, pw);
  p.x_label = "scene value (relative, 1 = diffuse white)";
  p.y_label = "display cd/m2";
  p.log_x = p.log_y = true;
  // Down to 0.01 cd/m2 so the curves' toes show; a little headroom above the peak so the
  // shoulders are not drawn on the frame.
  p.x_min = 1e-3, p.x_max = 1e3, p.y_min = 0.01, p.y_max = peak * 2;
  p.x_ticks = {1e-3, 1e-2, 0.1, 1, 10, 100, 1000};
  for (double y = p.y_min; y <= p.y_max; y *= 10)
    if (y < peak / 1.5) p.y_ticks.push_back(y);
  p.y_ticks.push_back(pw);
  p.y_ticks.push_back(peak);
  const tonemap::Display d{peak, black, pw};
  std::size_t i = 0;
  for (const auto& info : tonemap::curves()) {
    auto curve = tonemap::prepare(info.name, d);
    if (!curve) continue;
    // More curves than distinct colours: the next rounds of the palette are dashed.
    const SeriesStyle style = series_style(i++);
    Series s{std::string(info.name), style.colour, {}, style.dash};
    for (int k = 0; k <= 300; ++k) {
      const double x = std::pow(10.0, -3 + 6.0 * k / 300);
      s.points.push_back({x, (*curve)->map(x) * pw});
    }
    p.series.push_back(std::move(s));
  }
  return p;
}

double fresnel_conductor(double cos_theta, double n, double k) {
  const double c2 = cos_theta * cos_theta, s2 = 1 - c2;
  const double t0 = n * n - k * k - s2;
  const double a2b2 = std::sqrt(std::max(0.0, t0 * t0 + 4 * n * n * k * k));
  const double a = std::sqrt(std::max(0.0, 0.5 * (a2b2 + t0)));
  const double t1 = a2b2 + c2, t2 = 2 * cos_theta * a;
  const double rs = (t1 - t2) / (t1 + t2);
  const double t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
  const double rp = rs * (t3 - t4) / (t3 + t4);
  return 0.5 * (rs + rp);
}

Plot fresnel_plot() {
  Plot p;
  p.title = "Fresnel reflectance of RTR4 table 9.2 metals (luminance of RGB F)";
  p.x_label = "sin theta";
  p.y_label = "F";
  p.x_min = 0, p.x_max = 1, p.y_min = 0, p.y_max = 1;
  for (int i = 0; i <= 10; ++i) p.x_ticks.push_back(i / 10.0), p.y_ticks.push_back(i / 10.0);
  const color::Vec3 luma = color::kRec709Luma;
  std::size_t metal_index = 0;
  for (const auto& m : shading::f0_presets()) {
    if (m.kind != shading::PresetKind::metal) continue;
    const double f0[3] = {m.f0_air.x, m.f0_air.y, m.f0_air.z};
    // Most metals' F0 is near grey: a palette colour per metal keeps the lines apart.
    const Rgb8 col = palette(metal_index++);
    Series schlick{std::string(m.name), col, {}};
    for (int i = 0; i <= 200; ++i) {
      const double s = i / 200.0, ct = std::sqrt(std::max(0.0, 1 - s * s));
      double f = 0;
      for (int c = 0; c < 3; ++c) f += luma[c] * (f0[c] + (1 - f0[c]) * std::pow(1 - ct, 5));  // RTR4 eq. 9.16
      schlick.points.push_back({s, f});
    }
    p.series.push_back(std::move(schlick));
    if (!m.f0_water) continue;  // n (hence k) known only where table 9.4 gives in-water F0
    const auto n = shading::preset_metal_n(m);
    const double nn[3] = {n.x, n.y, n.z};
    Series exact{std::string(m.name) + " exact", col, {}, 5};
    for (int i = 0; i <= 200; ++i) {
      const double s = i / 200.0, ct = std::sqrt(std::max(0.0, 1 - s * s));
      double f = 0;
      for (int c = 0; c < 3; ++c) {
        const double f0c = std::min(f0[c], 0.9999);
        // F0 = ((n-1)^2 + k^2) / ((n+1)^2 + k^2) solved for k.
        const double k2 = std::max(0.0, (f0c * (nn[c] + 1) * (nn[c] + 1) - (nn[c] - 1) * (nn[c] - 1)) / (1 - f0c));
        f += luma[c] * fresnel_conductor(ct, nn[c], std::sqrt(k2));
      }
      exact.points.push_back({s, f});
    }
    p.series.push_back(std::move(exact));
  }
  return p;
}

// ---- Heatmap -----------------------------------------------------------------------------
Rgb8 heat_colour(double nits) {
  // Stops every decade from 0.01 to 10000 cd/m2 (log scale): dark blue .. white.
  static constexpr Rgb8 stops[] = {{0, 0, 40}, {0, 0, 160}, {0, 120, 255}, {0, 200, 120}, {240, 230, 0},
                                   {255, 120, 0}, {220, 0, 0}, {255, 255, 255}};
  const double t = std::clamp((std::log10(std::max(nits, 1e-6)) + 2) / 6.0, 0.0, 1.0) * 7;
  const int i = std::min(6, static_cast<int>(t));
  const double u = t - i;
  Rgb8 c;
  for (int k = 0; k < 3; ++k) c[k] = std::uint8_t(std::lround(stops[i][k] * (1 - u) + stops[i + 1][k] * u));
  return c;
}

Image luminance_image(const Image& nits, const color::Primaries& primaries) {
  const color::Vec3 w = color::luminance_weights(primaries);
  Image out(nits.width, nits.height);
  for (std::size_t i = 0; i < nits.pixel_count(); ++i) {
    const float* p = &nits.rgba[i * 4];
    const float y = static_cast<float>(w.x * p[0] + w.y * p[1] + w.z * p[2]);
    out.rgba[i * 4] = out.rgba[i * 4 + 1] = out.rgba[i * 4 + 2] = y;
    out.rgba[i * 4 + 3] = 1;
  }
  return out;
}

// Title row (scale-2 text), then the picture; the legend column right of it with its
// "CD/M2" caption above the bar and decade labels beside it.
HeatmapLayout heatmap_layout(int image_width, int image_height) {
  constexpr int kHead = 24, kLegendColumn = 110, kMinHeight = 260;
  HeatmapLayout l;
  l.image_x = 0, l.image_y = kHead;
  l.width = image_width + kLegendColumn;
  l.height = std::max(image_height + kHead, kMinHeight);
  l.legend_x = image_width + 10, l.legend_width = 20;
  l.legend_top = kHead + 20;  // room for the caption, clear of the top label
  l.legend_bottom = l.height - 12;
  return l;
}

int HeatmapLayout::legend_row(double nits) const {
  const double t = (4 - std::log10(std::clamp(nits, 0.01, 10000.0))) / 6;
  return legend_top + static_cast<int>(std::lround(t * (legend_bottom - legend_top)));
}

double HeatmapLayout::legend_nits(int row) const {
  return std::pow(10.0, 4 - 6.0 * (row - legend_top) / (legend_bottom - legend_top));
}

Canvas8 heatmap(const Image& lum, const std::string& title) {
  const HeatmapLayout l = heatmap_layout(lum.width, lum.height);
  const Rgb8 black{0, 0, 0};
  Canvas8 c(std::max(l.width, text_width(title, 2) + 8), l.height, {255, 255, 255});
  c.text(title, 4, 5, black, 2);
  for (int y = 0; y < lum.height; ++y)
    for (int x = 0; x < lum.width; ++x) c.set(l.image_x + x, l.image_y + y, heat_colour(lum.px(x, y)[0]));
  for (int y = l.legend_top; y <= l.legend_bottom; ++y)
    c.fill(l.legend_x, y, l.legend_x + l.legend_width, y + 1, heat_colour(l.legend_nits(y)));
  const int tick_x = l.legend_x + l.legend_width;
  for (int d = -2; d <= 4; ++d) {
    const int y = l.legend_row(std::pow(10.0, d));
    c.line(tick_x, y, tick_x + 4, y, black);
    c.text(fmt::format("{:g}", std::pow(10.0, d)), tick_x + 7, y - 3, black);
  }
  c.text("CD/M2", l.legend_x, l.legend_top - 16, black);
  return c;
}

Image decoded_luminance(const EncodedFrame& f) {
  Image nits(f.width, f.height);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const color::Vec3 n = decode_pixel(f, x, y);
      float* p = nits.px(x, y);
      p[0] = float(n.x), p[1] = float(n.y), p[2] = float(n.z), p[3] = 1;
    }
  return luminance_image(nits, f.target.container());
}

Canvas8 frame_heatmap(const EncodedFrame& f) {
  return heatmap(decoded_luminance(f),
                 fmt::format("DISPLAY CD/M2, {} PEAK {:g}", to_string(f.target.mode), f.target.peak_nits));
}

// ---- Contact sheet -----------------------------------------------------------------------
Image downscale(const Image& img, int max_width) {
  if (img.width <= max_width) return img;
  const int f = (img.width + max_width - 1) / max_width;
  Image out(img.width / f, img.height / f);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      double acc[4] = {0, 0, 0, 0};
      for (int j = 0; j < f; ++j)
        for (int i = 0; i < f; ++i)
          for (int k = 0; k < 4; ++k) acc[k] += img.px(x * f + i, y * f + j)[k];
      for (int k = 0; k < 4; ++k) out.px(x, y)[k] = static_cast<float>(acc[k] / (f * f));
    }
  return out;
}

Canvas8 contact_sheet(const std::vector<SheetTile>& tiles, const std::string& title, int columns) {
  int tw = 64, th = 36;
  for (const auto& t : tiles)
    if (t.frame) tw = std::max(tw, t.frame->width), th = std::max(th, t.frame->height);
  const int pad = 8, label = 14, head = 30;
  const int rows = (static_cast<int>(tiles.size()) + columns - 1) / columns;
  Canvas8 c(columns * (tw + pad) + pad, head + rows * (th + label + pad) + pad, {40, 40, 40});
  c.text(title, pad, 8, {235, 235, 235}, 2);
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const int x0 = pad + int(i % columns) * (tw + pad), y0 = head + int(i / columns) * (th + label + pad);
    const SheetTile& t = tiles[i];
    if (t.frame) {
      for (int y = 0; y < t.frame->height; ++y)
        for (int x = 0; x < t.frame->width; ++x) {
          const std::uint8_t* px = t.frame->data.data() + y * t.frame->stride_bytes + x * 4;
          c.set(x0 + x, y0 + y, {px[2], px[1], px[0]});
        }
    } else {
      c.fill(x0, y0, x0 + tw, y0 + th, {90, 20, 20});
      c.text(t.error.substr(0, static_cast<std::size_t>(tw / kGlyphAdvance)), x0 + 2, y0 + th / 2, {255, 200, 200});
    }
    c.text(t.label, x0, y0 + th + 4, {235, 235, 235});
  }
  return c;
}

}  // namespace hdrd::patterns

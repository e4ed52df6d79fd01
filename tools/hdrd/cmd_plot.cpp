// hdrd plot curves|fresnel: pictures of what the tone curves and the Fresnel term do. SVG or PNG by the output's extension (PNG: 8-bit sRGB, own raster).
#include <filesystem>
#include <span>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "patterns/plot.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct PlotOptions {
  CommonOptions common;
  std::string output;
  double peak_nits = 1000, paper_white_nits = 203, black_nits = 0.005;
  int width = 960, height = 600;
};

bool is_svg(const std::string& path) { return std::filesystem::path(path).extension() == ".svg"; }

void write_bytes(const std::string& path, std::span<const std::uint8_t> bytes) {
  if (auto ok = io::atomic_write(path, bytes); !ok) throw HdrdError(ok.error());
}

void write_canvas(const std::string& path, const patterns::Canvas8& c) {
  auto png = c.png();
  if (!png) throw HdrdError(png.error());
  write_bytes(path, *png);
}

void write_plot(const PlotOptions& o, patterns::Plot plot) {
  if (o.output.empty()) throw CliError("-o OUTPUT (.svg or .png) is required");
  plot.width = o.width, plot.height = o.height;
  if (is_svg(o.output)) {
    const std::string svg = patterns::render_svg(plot);
    write_bytes(o.output, std::span(reinterpret_cast<const std::uint8_t*>(svg.data()), svg.size()));
  } else {
    write_canvas(o.output, patterns::render_raster(plot));
  }
  nlohmann::json j = {{"output", o.output}, {"title", plot.title}, {"series", nlohmann::json::array()}};
  for (const auto& s : plot.series) j["series"].push_back(s.name);
  print_out(o.common.json ? j.dump(2) : fmt::format("wrote {} ({} series)\n", o.output, plot.series.size()));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<PlotOptions>();
  auto* app = root.add_subcommand("plot", "Plot tone curves or Fresnel reflectance");
  app->require_subcommand(1);
  auto* curves = app->add_subcommand("curves", "Every tone curve: display cd/m2 against scene value, log axes");
  curves->add_option("--peak", o->peak_nits, "Display peak, cd/m2")->capture_default_str();
  curves->add_option("--paper-white", o->paper_white_nits, "Paper white, cd/m2")->capture_default_str();
  curves->add_option("--black", o->black_nits, "Display black, cd/m2")->capture_default_str();
  auto* fresnel = app->add_subcommand("fresnel", "F against sin theta for the RTR4 table 9.2 metals, Schlick vs exact");
  for (auto* sub : {curves, fresnel}) {
    sub->add_option("-o,--output", o->output, "Output .svg or .png")->required();
    sub->add_option("--width", o->width, "Picture width (default 960)");
    sub->add_option("--height", o->height, "Picture height (default 600)");
    add_common_options(*sub, o->common);
  }
  app->footer(
      "Examples:\n"
      "  hdrd plot curves --peak 1000 -o curves.svg\n"
      "  hdrd plot curves --peak 600 -o curves-600.png\n"
      "  hdrd plot fresnel -o fresnel.svg\n"
      "The heatmap of an encode is one of its outputs: hdrd encode Desk.exr -o desk --format heatmap.");
  curves->callback([o] { write_plot(*o, patterns::tone_curves_plot(o->peak_nits, o->paper_white_nits, o->black_nits)); });
  fresnel->callback([o] { write_plot(*o, patterns::fresnel_plot()); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("plot", 50, &hdrd::cli::setup)

// hdrd plot curves|fresnel|heatmap: pictures of what the tone curves, the Fresnel term
// and the encoder do. SVG or PNG by the output's extension (PNG: 8-bit sRGB, own raster).
#include <filesystem>
#include <span>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "patterns/plot.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/pipeline_options.hpp"

namespace hdrd::cli {
namespace {

struct PlotOptions {
  CommonOptions common;
  std::string output;
  double peak_nits = 1000, paper_white_nits = 203, black_nits = 0.005;
  int width = 960, height = 600;
  // heatmap
  PipelineOptions pipeline;
  std::string input;
  int max_width = 960;
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

void run_heatmap(const PlotOptions& o) {
  set_progress_enabled(!o.common.quiet);
  if (o.output.empty()) throw CliError("-o OUTPUT.png is required");
  std::vector<std::string> notes;
  EncodeSettings settings = build_settings(o.pipeline, exposure::Mode::manual, &notes);
  auto exr = io::read_exr(o.input);
  if (!exr) throw HdrdError(exr.error());
  const Image small = patterns::downscale(exr->image, o.max_width);
  SceneInput in;
  in.image = &small;
  in.to_working = exr->to_working();
  in.units = exr->white_luminance ? InputUnits::absolute : InputUnits::relative;
  in.white_luminance_nits = exr->white_luminance.value_or(1.0);
  auto frame = encode_frame(in, settings);
  if (!frame) throw HdrdError(frame.error());
  // The same picture as `--debug heatmap`: display cd/m2 decoded from the encoded codes.
  write_canvas(o.output, patterns::frame_heatmap(*frame));
  print_out(o.common.json ? nlohmann::json{{"output", o.output}, {"max_cll_nits", frame->content_light.max_cll_nits}}.dump(2)
                          : fmt::format("wrote {}\n", o.output));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<PlotOptions>();
  auto* app = root.add_subcommand("plot", "Plot tone curves, Fresnel reflectance or a display-luminance heatmap");
  app->require_subcommand(1);
  auto* curves = app->add_subcommand("curves", "Every tone curve: display cd/m2 against scene value, log axes");
  curves->add_option("--peak", o->peak_nits, "Display peak, cd/m2")->capture_default_str();
  curves->add_option("--paper-white", o->paper_white_nits, "Paper white, cd/m2")->capture_default_str();
  curves->add_option("--black", o->black_nits, "Display black, cd/m2")->capture_default_str();
  auto* fresnel = app->add_subcommand("fresnel", "F against sin theta for the RTR4 table 9.2 metals, Schlick vs exact");
  auto* heat = app->add_subcommand("heatmap", "False-colour map of the display luminance an encode produces");
  heat->add_option("input", o->input, "Input OpenEXR")->required();
  heat->add_option("--max-width", o->max_width, "Downscale to at most this width (default 960)");
  add_pipeline_options(*heat, o->pipeline);
  for (auto* sub : {curves, fresnel, heat}) {
    sub->add_option("-o,--output", o->output, sub == heat ? "Output .png" : "Output .svg or .png")->required();
    if (sub != heat) {
      sub->add_option("--width", o->width, "Picture width (default 960)");
      sub->add_option("--height", o->height, "Picture height (default 600)");
    }
    add_common_options(*sub, o->common);
  }
  app->footer(
      "Examples:\n"
      "  hdrd plot curves --peak 1000 -o curves.svg\n"
      "  hdrd plot curves --peak 600 -o curves-600.png\n"
      "  hdrd plot fresnel -o fresnel.svg\n"
      "  hdrd plot heatmap Desk.exr --mode hdr10 --peak 1000 --tonemap bt2390 -o desk-heat.png\n"
      "The heatmap shows display luminance (cd/m2, log scale 0.01..10000) after the encode's tone curve.");
  curves->callback([o] { write_plot(*o, patterns::tone_curves_plot(o->peak_nits, o->paper_white_nits, o->black_nits)); });
  fresnel->callback([o] { write_plot(*o, patterns::fresnel_plot()); });
  heat->callback([o] { run_heatmap(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("plot", 50, &hdrd::cli::setup)

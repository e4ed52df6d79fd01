// hdrctl's command-line options and the JSON request bodies they make (docs/api.md,
// "Request fields"). Option groups follow the API: the display target, the scene-referred
// pipeline (render, encode), the answer (file, format, dump), and the patterns'
// parameters.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace hdrctl {

struct Failure {  // one line on stderr, then this exit status
  int exit_code;
  std::string message;
};

// display.*
struct DisplayOptions {
  std::optional<std::string> mode, range, sdr_curve, display;
  std::optional<double> peak, black, paper_white, ui_white, sdr_white;
  std::optional<int> bits;
};

// Tone curve, exposure, gamut, grading and UI overlay: render and encode only.
struct PipelineOptions {
  std::optional<std::string> tonemap, tonemap_apply, exposure_mode, gamut, lut, lut_shaper, grade_placement, ui,
      ui_upload;
  std::optional<double> exposure_ev, ev100, ui_scale, ui_dim;
  std::vector<std::string> tonemap_params;
  std::vector<int> ui_pos;
};

// Where the answer goes, and the request file / --set overrides every body starts from.
struct OutputOptions {
  std::string request_file;
  std::vector<std::string> sets;
  std::string output, format;
  bool dump = false;
  std::string dump_formats;
  std::optional<std::string> name;
};

struct FrameOptions {
  DisplayOptions display;
  PipelineOptions pipeline;
  OutputOptions out;
};

struct PatternOptions {
  DisplayOptions display;
  OutputOptions out;
  std::string name;
  bool list = false;
  std::optional<int> width, height, steps;
  std::optional<double> level, area;
  bool no_labels = false;
};

std::string read_all(const std::string& path);  // "-": stdin

void add_display_options(CLI::App* app, DisplayOptions& o);
void add_pipeline_options(CLI::App* app, PipelineOptions& o);
void add_output_options(CLI::App* app, OutputOptions& o);
void add_pattern_options(CLI::App* app, PatternOptions& o);

// Request bodies: the --request file, then the options, then every --set.
nlohmann::json frame_body(const FrameOptions& o, const nlohmann::json& extra = nlohmann::json::object());
nlohmann::json pattern_body(const PatternOptions& o);

// The Accept header for the answer: JSON for a dump, else from --format or -o's extension.
std::string accept_for(const OutputOptions& o);

}  // namespace hdrctl

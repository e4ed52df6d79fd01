// The display, exposure, tone-mapping, UI and output options that `hdrd encode` and
// `hdrd render` share, registered once and turned into hdrd::EncodeSettings.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"

namespace hdrd::cli {

struct PipelineOptions {
  std::string mode;  // empty: the display profile's mode (--edid/--display), else hdr10
  std::optional<double> peak_nits, black_nits, paper_white_nits, ui_white_nits, sdr_white_nits;
  std::string range = "full";
  std::optional<int> bits;
  std::string sdr_curve = "srgb";
  std::string tonemap;
  std::vector<std::string> tonemap_params;  // k=v
  std::string tonemap_apply;
  std::string gamut = "ictcp";
  // exposure
  std::string exposure_mode;  // empty: the command's default
  double exposure_ev = 0;
  std::optional<double> ev100, aperture, shutter, iso, gain, illuminance;
  std::optional<double> percentile, percentile_target, ignore_dark, ignore_bright;
  // UI
  std::string ui_path;
  bool ui_premultiplied = false;
  std::vector<int> ui_pos;
  double ui_scale = 1.0;
  std::string ui_blend = "linear";
  double ui_dim = 0.0;
  // grading
  std::string lut_path, lut_shaper, grade_placement, ocio_config, ocio_look, ocio_display, ocio_view;
  bool lut_trilinear = false;
  // display
  std::string display;   // "auto" or a connector name
  std::string edid_path;
  std::string profile_override;  // a display profile override file (TOML/JSON)
  // output
  std::string formats;   // "png,exr,raw"
  bool dither = false;
  int threads = 0;
  std::vector<std::string> debug;  // --debug heatmap (encode, render)
};

// Adds the options to a subcommand.
void add_pipeline_options(CLI::App& app, PipelineOptions& o);

// Builds the settings; throws HdrdError naming the option on any invalid value.
// `default_exposure` is used when --exposure-mode is not given.
EncodeSettings build_settings(const PipelineOptions& o, exposure::Mode default_exposure,
                              std::vector<std::string>* notes);

// The dump formats asked for (default: all that apply to the mode).
std::vector<io::DumpFormat> build_formats(const PipelineOptions& o, Mode mode);

// --debug NAME[,NAME]: extra pictures next to the dumps (docs/patterns.md). Only `hdrd
// encode` and `hdrd render` take it.
void add_debug_option(CLI::App& app, PipelineOptions& o);
struct DebugOutputs {
  bool heatmap = false;  // OUTBASE.heatmap.png: false colour of the decoded display luminance
};
// Checks the --debug values (throws HdrdError naming an unknown one): call before any work.
DebugOutputs parse_debug(const PipelineOptions& o);
// The asked-for debug pictures, to be written with the dumps (io::write_dumps lists them
// in the sidecar, and so in --json).
std::vector<io::ExtraFile> debug_files(const EncodedFrame& frame, const DebugOutputs& debug);

// The sidecar-style summary printed by encode/render (--json) and its human form.
std::string summary_text(const EncodedFrame& f, const io::DumpResult& dumps, bool json,
                         const std::vector<std::string>& notes);

}  // namespace hdrd::cli

// hdrd pattern NAME -o OUTBASE: standard HDR test patterns (docs/patterns.md), written as
// the same dumps (PNG/EXR/raw + JSON sidecar) as `hdrd encode`.
#include <algorithm>

#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "patterns/patterns.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/pipeline_options.hpp"

namespace hdrd::cli {
namespace {

struct PatternCmdOptions {
  CommonOptions common;
  PipelineOptions pipeline;
  std::string name;
  std::string outbase;
  bool list = false;
  patterns::PatternOptions pattern;
  bool no_labels = false;
};

void print_list(bool json) {
  if (json) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& p : patterns::patterns())
      j.push_back({{"name", p.name}, {"description", p.description}, {"source", p.source}});
    print_out(j.dump(2));
    return;
  }
  std::string s;
  for (const auto& p : patterns::patterns()) s += fmt::format("{:11} {} ({})\n", p.name, p.description, p.source);
  print_out(s);
}

void run(const PatternCmdOptions& o) {
  set_progress_enabled(!o.common.quiet);
  if (o.list) return print_list(o.common.json);
  if (o.name.empty()) throw CliError("a pattern name is required (see hdrd pattern --list)");
  if (o.outbase.empty()) throw CliError("-o OUTBASE is required");
  std::vector<std::string> notes;
  EncodeSettings settings = build_settings(o.pipeline, exposure::Mode::manual, &notes);
  if (!o.pipeline.tonemap.empty() || !o.pipeline.lut_path.empty() || !o.pipeline.ui_path.empty())
    notes.push_back("patterns are display-referred: tone curve, grading and UI options are ignored");
  auto formats = build_formats(o.pipeline, settings.target.mode);
  const bool want_exr = std::find(formats.begin(), formats.end(), io::DumpFormat::exr) != formats.end();
  patterns::PatternOptions po = o.pattern;
  po.labels = !o.no_labels;
  auto frame = patterns::make_pattern(o.name, settings.target, po, want_exr);
  if (!frame) throw HdrdError(frame.error());
  if (o.name == "bt2111" && settings.target.range != Range::narrow)
    notes.push_back("bt2111 is defined in narrow range: written with --range narrow");
  if (frame->settings["pattern"].contains("note")) notes.push_back(frame->settings["pattern"]["note"].get<std::string>());
  auto dumps = io::write_dumps(*frame, o.outbase, formats);
  if (!dumps) throw HdrdError(dumps.error());
  progress("wrote pattern {} ({}x{}, {})", o.name, frame->width, frame->height, to_string(frame->target.mode));
  print_out(summary_text(*frame, *dumps, o.common.json, notes));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<PatternCmdOptions>();
  auto* app = root.add_subcommand("pattern", "Write a standard HDR test pattern for a display mode");
  app->add_option("name", o->name, "Pattern: bt2111, pq-ramp, window, near-black, clipping, sdr-grey");
  app->add_option("-o,--output", o->outbase, "Output base path: OUTBASE.png/.exr/.raw and OUTBASE.json");
  app->add_flag("--list", o->list, "List the patterns");
  app->add_option("--width", o->pattern.width, "Width in pixels (default 1920)");
  app->add_option("--height", o->pattern.height, "Height in pixels (default 1080)");
  app->add_option("--level", o->pattern.level_nits, "window/clipping: level in cd/m2 (default: the display peak)");
  app->add_option("--area", o->pattern.area_percent, "window: area in percent of the frame (1, 2, 10, 25, 50, 100; default 10)");
  app->add_option("--steps", o->pattern.steps, "pq-ramp, sdr-grey: number of steps (default 11); near-black: at most 10");
  app->add_flag("--no-labels", o->no_labels, "Do not draw the cd/m2 labels");
  add_pipeline_options(*app, o->pipeline);
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd pattern bt2111 --mode hdr10 -o out/bars-pq        (ITU-R BT.2111-2, narrow range)\n"
      "  hdrd pattern bt2111 --mode hlg -o out/bars-hlg\n"
      "  hdrd pattern window --mode hdr10 --peak 1000 --level 1000 --area 10 -o out/win10\n"
      "  hdrd pattern clipping --mode hdr10 --peak 10000 --level 1000 -o out/clip  (squares >= 1000 vanish)\n"
      "  hdrd pattern pq-ramp --mode hdr10 --steps 21 -o out/ramp --format png --json\n"
      "  hdrd pattern sdr-grey --mode hdr10 --sdr-white 203 -o out/sdr-grey\n"
      "Patterns are display-referred: levels are cd/m2 on the display, encoded with the clip curve.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("pattern", 40, &hdrd::cli::setup)

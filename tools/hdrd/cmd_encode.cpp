// hdrd encode INPUT.exr -o OUTBASE: scene-referred EXR to display signals.
#include <chrono>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/pipeline_options.hpp"

namespace hdrd::cli {
namespace {

struct EncodeOptions {
  CommonOptions common;
  PipelineOptions pipeline;
  std::string input;
  std::string outbase;
  std::string input_units;  // relative|absolute
};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void run(const EncodeOptions& o) {
  set_progress_enabled(!o.common.quiet);
  std::vector<std::string> notes;
  // Defaults for EXR input: manual exposure, 0 EV (REFERENCE.md §1.2).
  EncodeSettings settings = build_settings(o.pipeline, exposure::Mode::manual, &notes);
  const auto formats = build_formats(o.pipeline, settings.target.mode);
  const DebugOutputs debug = parse_debug(o.pipeline);
  auto wants = [&](io::DumpFormat f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
  settings.keep_display_nits = wants(io::DumpFormat::exr);
  settings.png_samples = wants(io::DumpFormat::png);

  if (settings.exposure.mode == exposure::Mode::light && !settings.exposure.illuminance_lux)
    throw CliError("--exposure-mode light needs --illuminance LUX for an EXR input (a render knows its sun)");

  auto t0 = std::chrono::steady_clock::now();
  auto exr = io::read_exr(o.input);
  if (!exr) throw HdrdError(exr.error());
  progress("read {} ({}x{}, {}) in {:.0f} ms", o.input, exr->image.width, exr->image.height,
           exr->compression, ms_since(t0));

  SceneInput in;
  in.image = &exr->image;
  in.to_working = exr->to_working();
  // REFERENCE.md §1.1: relative unless the file has whiteLuminance or --input says otherwise.
  if (o.input_units.empty()) {
    in.units = exr->white_luminance ? InputUnits::absolute : InputUnits::relative;
  } else {
    const auto u = parse_input_units(o.input_units);
    if (!u) throw CliError("--input: '" + o.input_units + "' is not relative or absolute");
    in.units = *u;
  }
  in.white_luminance_nits = exr->white_luminance.value_or(1.0);
  if (in.units == InputUnits::absolute && !exr->white_luminance)
    notes.push_back("--input absolute without whiteLuminance: values are taken as cd/m2");

  t0 = std::chrono::steady_clock::now();
  auto frame = encode_frame(in, settings);
  if (!frame) throw HdrdError(frame.error());
  progress("encoded {} in {:.0f} ms", to_string(settings.target.mode), ms_since(t0));
  frame->settings["input"] = {{"path", o.input},
                              {"units", to_string(in.units)},
                              {"white_luminance_nits", in.white_luminance_nits},
                              {"channels", exr->channels}};

  t0 = std::chrono::steady_clock::now();
  auto dumps = io::write_dumps(*frame, o.outbase, formats, debug_files(*frame, debug));
  if (!dumps) throw HdrdError(dumps.error());
  progress("wrote {} files in {:.0f} ms", dumps->files.size(), ms_since(t0));
  print_out(summary_text(*frame, *dumps, o.common.json, notes));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<EncodeOptions>();
  auto* app = root.add_subcommand("encode", "Encode a scene-referred OpenEXR image for a display mode");
  app->add_option("input", o->input, "Input OpenEXR (relative: 1.0 = diffuse white; absolute with whiteLuminance)")
      ->required();
  app->add_option("-o,--output", o->outbase, "Output base path: writes OUTBASE.png/.exr/.raw and OUTBASE.json")
      ->required();
  app->add_option("--input", o->input_units, "relative or absolute (default: absolute when the file has whiteLuminance)");
  add_pipeline_options(*app, o->pipeline);
  add_debug_option(*app, o->pipeline);
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd encode Desk.exr -o out/desk --mode hdr10 --peak 1000\n"
      "  hdrd encode Desk.exr -o out/desk --mode hdr10 --debug heatmap   (+ out/desk.heatmap.png)\n"
      "  hdrd encode Desk.exr -o out/desk-sdr --mode sdr --tonemap aces-narkowicz --exposure -1\n"
      "  hdrd encode frame.exr -o out/f --mode hdr10 --tonemap clip --format png --json\n"
      "  hdrd encode Desk.exr -o out/d --mode hlg --exposure-mode histogram --ui hud.png --ui-pos 16,16\n"
      "Every dump gets OUTBASE.json describing exactly what is in it (see docs/dump-format.md).");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("encode", 20, &hdrd::cli::setup)

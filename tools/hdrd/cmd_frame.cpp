// hdrd render / encode / pattern: the three sources of the one frame job (job/frame_job.hpp).
// Each subcommand's options are the settings table's (job/settings.hpp); what the user typed
// becomes the same JSON request the daemon takes, parsed by the same parser, run by the
// same job. Only the transport is the CLI's: paths as given, OUTBASE files, stdout/stderr.
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/video/writer.hpp"
#include "job/frame_job.hpp"
#include "job/sequence.hpp"
#include "patterns/patterns.hpp"
#include "tools/common/progress_bar.hpp"
#include "tools/common/settings_cli.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/frame_args.hpp"

namespace hdrd::cli {
namespace {

struct FrameCommand {
  job::Source source = job::Source::render;
  CommonOptions common;
  SettingArgs args;
  std::string outbase;
  std::string input;    // encode: the EXR
  std::string pattern;  // pattern: its name
  bool list = false;    // pattern --list
};

void print_pattern_list(bool json) {
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

// The request as the CLI spells it: paths are the user's own (no asset root).
job::ParseContext cli_context(job::Source source) {
  job::ParseContext ctx;
  ctx.source = source;
  ctx.spelling = job::Spelling::cli;
  ctx.reach = job::Reach::cli;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<std::filesystem::path> {
    return std::filesystem::path(p);
  };
  return ctx;
}

std::string summary_text(const job::FrameResult& r, const std::map<std::string, std::string>& files, bool json) {
  if (json) {
    nlohmann::json j = r.sidecar();
    j["files"] = files;
    j["timings_ms"] = r.timings_ms;
    return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  }
  const auto& f = r.frame;
  std::string s = fmt::format("{} {}x{} {} peak {} cd/m2, paper white {} cd/m2", to_string(f.target.mode), f.width,
                              f.height, fourcc_name(f.drm_fourcc), f.target.peak_nits, f.target.paper_white_nits);
  if (f.target.is_hdr())
    s += fmt::format(", MaxCLL {:.0f}, MaxFALL {:.0f}", std::ceil(f.content_light.max_cll_nits),
                     std::ceil(f.content_light.max_fall_nits));
  s += "\n";
  for (const auto& [kind, path] : files) s += fmt::format("  {:9} {}\n", kind, path);
  for (const auto& w : r.warnings) s += "  note: " + w + "\n";
  return s;
}

// What the job did and how long each stage took, on stderr (the result is stdout's).
void report_progress(const job::FrameResult& r) {
  const auto& t = r.timings_ms;
  auto ms = [&](const char* stage) { return t.contains(stage) ? t[stage].get<double>() : 0.0; };
  const auto& f = r.frame;
  if (f.settings.contains("render")) {
    const auto& rd = f.settings["render"];
    progress("rendered {} at {}x{} ({}x MSAA) on {} ({}) in {:.0f} ms", rd.value("scene", ""), f.width, f.height,
             rd.value("samples", 1), rd.value("backend", ""), rd.value("gl_renderer", ""), ms("render"));
  }
  if (t.contains("read")) progress("read the EXR in {:.0f} ms", ms("read"));
  progress("encoded {} {}x{} on the {} in {:.0f} ms", to_string(f.target.mode), f.width, f.height, r.encoder,
           ms("encode"));
  progress("made {} output{} in {:.0f} ms", r.files.size(), r.files.size() == 1 ? "" : "s", ms("outputs"));
}

std::string sequence_summary(const job::SequenceResult& r, bool json) {
  if (json) return r.sidecar.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  const auto& j = r.sidecar;
  std::string s = fmt::format("{} {}x{}: {} frames at {:g} fps, {} scene{}", j.value("mode", ""), j.value("width", 0),
                              j.value("height", 0), r.frames, j.value("fps", 0.0), j["scenes"].size(),
                              j["scenes"].size() == 1 ? "" : "s");
  if (j.contains("content_light_level") && j["content_light_level"].value("max_cll_nits", 0.0) > 0)
    s += fmt::format(", MaxCLL {:.0f}, MaxFALL {:.0f}", j["content_light_level"].value("max_cll_nits", 0.0),
                     j["content_light_level"].value("max_fall_nits", 0.0));
  s += "\n";
  for (const auto& [kind, path] : r.files) s += fmt::format("  {:12} {}\n", kind, path);
  for (const auto& w : r.warnings) s += "  note: " + w + "\n";
  return s;
}

// "render 80.1 ms, encode 3.2 ms, ...": the stages a sequence ran, per frame. A render
// sequence renders, an EXR sequence reads; a stage it never ran is left out, not shown as 0.
std::string per_frame_stages(const nlohmann::json& timings_ms, int frames) {
  std::string s;
  for (const char* stage : {"render", "read", "encode", "dumps", "video"}) {
    if (!timings_ms.contains(stage) || !timings_ms[stage].is_number()) continue;
    s += fmt::format("{}{} {:.1f} ms", s.empty() ? "" : ", ", stage, timings_ms[stage].get<double>() / std::max(1, frames));
  }
  return s.empty() ? "no stage timed" : s;
}
// Ctrl-C / SIGTERM during a sequence: the job stops at its next frame as the daemon's cancel
// does (run_sequence removes what it wrote: staged frames, the video spool), then hdrd exits.
std::atomic<int> g_stop_signal{0};
extern "C" void on_sequence_signal(int sig) { g_stop_signal.store(sig); }

struct SequenceSignals {
  SequenceSignals() {
    old_int = std::signal(SIGINT, on_sequence_signal);
    old_term = std::signal(SIGTERM, on_sequence_signal);
  }
  ~SequenceSignals() {
    std::signal(SIGINT, old_int);
    std::signal(SIGTERM, old_term);
  }
  void (*old_int)(int) = nullptr;
  void (*old_term)(int) = nullptr;
};

// hdrd render --frames N / hdrd encode 'shot.%04d.exr': the sequence job (job/sequence.hpp).
void run_sequence(const FrameCommand& o, job::FrameRequest request) {
  video::quiet_codec_logs();
  job::SequenceOptions options;
  options.job.threads = static_cast<int>(request.integer("threads"));
  options.job.should_stop = [] { return g_stop_signal.load() != 0; };
  ProgressBar bar("hdrd:", progress_enabled());
  options.progress = [&bar](const job::SequenceProgress& p) { bar.update(p.frames_done, p.frames_total, p.fps, p.eta_s); };
  Result<job::SequenceResult> result = make_error("internal", "not run");
  {
    const SequenceSignals signals;
    result = job::run_sequence(request, o.outbase, options);
  }
  bar.finish();
  if (const int sig = g_stop_signal.load(); sig && !result)  // (a signal after the last frame: it is done)
    throw HdrdError(make_error("request.cancelled", fmt::format("interrupted by {}: stopped, and the sequence's files were removed",
                                                                sig == SIGINT ? "SIGINT" : "SIGTERM")));
  if (!result) throw HdrdError(result.error());
  progress("per frame: {}", per_frame_stages(result->timings_ms, result->frames));
  print_out(sequence_summary(*result, o.common.json));
}

// The request JSON of what was typed, and whether it is a sequence: any sequence setting
// given, or an encode input that only a sequence can be (its frames then go in `images`).
std::pair<nlohmann::json, bool> request_doc(const FrameCommand& o) {
  auto doc = request_json(o.args);
  if (!doc) throw HdrdError(doc.error());
  if (o.source == job::Source::pattern) (*doc)["pattern"] = o.pattern;
  const bool sequence =
      o.source != job::Source::pattern &&
      (job::sets_sequence_settings(*doc) || (o.source == job::Source::encode && job::names_a_sequence(o.input)));
  if (sequence && o.source == job::Source::encode) (*doc)["images"] = o.input;
  return {std::move(*doc), sequence};
}

void run(const FrameCommand& o) {
  set_progress_enabled(!o.common.quiet);
  if (o.source == job::Source::pattern && o.list) return print_pattern_list(o.common.json);
  if (o.source == job::Source::pattern && o.pattern.empty())
    throw CliError("a pattern name is required (see hdrd pattern --list)");
  if (o.outbase.empty()) throw CliError("-o OUTBASE is required");
  auto [doc, sequence] = request_doc(o);
  auto ctx = cli_context(o.source);
  ctx.sequence = sequence;
  auto request = job::parse_request_json(doc, ctx);
  if (!request) throw HdrdError(request.error());
  job::JobOptions options;
  options.threads = static_cast<int>(request->integer("threads"));
  // Everything knowable before any work, as the daemon checks it before its 202.
  if (auto ok = job::check_request(*request, options, {.outbase = o.outbase, .spelling = job::Spelling::cli}); !ok)
    throw HdrdError(ok.error());
  if (ctx.sequence) return run_sequence(o, std::move(*request));
  job::EncodeInput input;
  if (o.source == job::Source::encode) input.path = o.input;
  auto frame_job = job::FrameJob::create(std::move(*request), options, input);
  if (!frame_job) throw HdrdError(frame_job.error());
  auto result = job::run_frame_job(**frame_job);
  if (!result) throw HdrdError(result.error());
  report_progress(*result);
  const auto t0 = std::chrono::steady_clock::now();
  auto files = job::write_outputs(*result, o.outbase);
  if (!files) throw HdrdError(files.error());
  progress("wrote {} files in {:.0f} ms", files->size(),
           std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  print_out(summary_text(*result, *files, o.common.json));
}

struct Spec {
  const char* name;
  int order;
  job::Source source;
  const char* description;
  const char* footer;
};

constexpr Spec kRender{
    "render", 15, job::Source::render, "Render a scene physically and encode it for a display mode",
    "Examples:\n"
    "  hdrd render --scene material-grid -o out/grid --mode hdr10 --peak 1000\n"
    "  hdrd render --scene hdr -o out/hdr --format png,heatmap     (+ out/hdr.heatmap.png, display cd/m2)\n"
    "  hdrd render --scene hdr -o out/hdr-sdr --mode sdr --tonemap aces-narkowicz --format png\n"
    "  hdrd render --scene model.glb -o out/model --width 1280 --height 720 --camera 0,1.5,4:0,0.5,0:40\n"
    "  hdrd render --scene furnace -o out/f --exposure-mode light --backend osmesa --json\n"
    "  hdrd render --scene hdr --frames 144 --fps 24 --video hevc -o out/walk   (out/walk.mp4 + sidecar)\n"
    "Writes OUTBASE.png/.exr/.raw, OUTBASE.scene.exr (float32 linear Rec.709, absolute cd/m2) and the\n"
    "sidecar OUTBASE.json. With --frames (or any sequence option) it renders a sequence: per-frame dumps\n"
    "OUTBASE.NNNNN.EXT, a video with --video, and the sequence sidecar OUTBASE.json (docs/sequences.md).\n"
    "Every option is a request setting (docs/settings.md): POST /v1/render (sequences: POST /v1/sequences)\n"
    "takes the same ones with the same defaults. Scenes: docs/scene-format.md; shading: docs/rendering.md."};
constexpr Spec kEncode{
    "encode", 20, job::Source::encode, "Encode a scene-referred OpenEXR image for a display mode",
    "Examples:\n"
    "  hdrd encode Desk.exr -o out/desk --mode hdr10 --peak 1000\n"
    "  hdrd encode Desk.exr -o out/desk --mode hdr10 --format png,heatmap   (+ out/desk.heatmap.png)\n"
    "  hdrd encode Desk.exr -o out/desk-sdr --mode sdr --tonemap aces-narkowicz --exposure -1\n"
    "  hdrd encode frame.exr -o out/f --mode hdr10 --tonemap clip --format png --json\n"
    "  hdrd encode Desk.exr -o out/d --mode hlg --exposure-mode histogram --ui hud.png --ui-pos 16,16\n"
    "  hdrd encode 'shot.%04d.exr' --video hevc --fps 24 -o out/shot   (or a directory, or a list.txt)\n"
    "Every dump gets OUTBASE.json describing exactly what is in it (docs/dump-format.md). Every option is a\n"
    "request setting (docs/settings.md): POST /v1/encode takes the same ones with the same defaults."};
constexpr Spec kPattern{
    "pattern", 40, job::Source::pattern, "Write a standard HDR test pattern for a display mode",
    "Examples:\n"
    "  hdrd pattern bt2111 --mode hdr10 -o out/bars-pq        (ITU-R BT.2111-2, narrow range)\n"
    "  hdrd pattern bt2111 --mode hlg -o out/bars-hlg\n"
    "  hdrd pattern window --mode hdr10 --peak 1000 --level 1000 --area 10 -o out/win10\n"
    "  hdrd pattern clipping --mode hdr10 --peak 600 -o out/clip  (squares at 0.7-1.5 x 600 over PQ's full\n"
    "      range, none clipped by hdrd: on the display, those at and above its clip point vanish)\n"
    "  hdrd pattern pq-ramp --mode hdr10 --steps 21 -o out/ramp --format png --json\n"
    "  hdrd pattern sdr-grey --mode hdr10 --sdr-white 203 -o out/sdr-grey\n"
    "Patterns are display-referred: levels are cd/m2 on the display, encoded with the clip curve."};

CLI::App* add_frame_command(CLI::App& root, const Spec& spec, const std::shared_ptr<FrameCommand>& o) {
  o->source = spec.source;
  auto* app = root.add_subcommand(spec.name, spec.description);
  if (spec.source == job::Source::encode)
    app->add_option("input", o->input,
                    "Input OpenEXR (relative: 1.0 = diffuse white; absolute with whiteLuminance); a sequence: a "
                    "frame pattern (shot.%04d.exr), a directory of .exr files or a list file (.txt)")
        ->required();
  if (spec.source == job::Source::pattern) {
    app->add_option("name", o->pattern, "Pattern: bt2111, pq-ramp, window, near-black, clipping, sdr-grey");
    app->add_flag("--list", o->list, "List the patterns");
  }
  app->add_option("-o,--output", o->outbase, "Output base path: OUTBASE.<format> for each format, and OUTBASE.json");
  add_setting_options(*app, spec.source, job::Reach::cli, o->args);
  add_common_options(*app, o->common);
  app->footer(spec.footer);
  return app;
}

void setup(CLI::App& root, const Spec& spec) {
  auto o = std::make_shared<FrameCommand>();
  add_frame_command(root, spec, o)->callback([o] { run(*o); });
}

}  // namespace

FrameArgs parse_frame_args(const std::vector<std::string>& args) {
  CLI::App app("hdrd");
  auto render = std::make_shared<FrameCommand>(), encode = std::make_shared<FrameCommand>();
  add_frame_command(app, kRender, render);
  add_frame_command(app, kEncode, encode);
  app.require_subcommand(1, 1);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    throw CliError(fmt::format("{}: {}", args.empty() ? "render|encode" : args.front(), e.what()));
  }
  const auto& o = app.got_subcommand("render") ? *render : *encode;
  FrameArgs out;
  out.source = o.source;
  std::tie(out.request, out.sequence) = request_doc(o);
  if (o.source == job::Source::encode) out.request["images"] = o.input;  // a plan is always a sequence
  return out;
}

}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("render", 15, [](CLI::App& root) { hdrd::cli::setup(root, hdrd::cli::kRender); })
HDRD_REGISTER_COMMAND("encode", 20, [](CLI::App& root) { hdrd::cli::setup(root, hdrd::cli::kEncode); })
HDRD_REGISTER_COMMAND("pattern", 40, [](CLI::App& root) { hdrd::cli::setup(root, hdrd::cli::kPattern); })

// hdrd present OUTBASE.json: show a raw dump on a display through KMS (atomic commit,
// HDR_OUTPUT_METADATA, Colorspace), or say clearly that no display is attached.
// hdrd present OUTBASE.%05d.json (a pattern, a directory, a list, the sequence sidecar or
// several sidecars): show the dumps in order at the mode's refresh rate or --fps with page
// flips (display/sequence_presenter.hpp), a progress line on stderr, statistics at the end.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <future>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/dump_reader.hpp"
#include "display/dump_sequence.hpp"
#include "display/presenter.hpp"
#include "job/settings.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

using namespace hdrd::display;

struct PresentCliOptions {
  CommonOptions common;
  std::vector<std::string> inputs;
  std::string device;
  std::string connector;
  std::string scrgb = "convert";
  double seconds = 10;
  bool test_only = false;
  double fps = 0;
  // The present.* settings of live output (hdrd render --present): one name, default and
  // description for both (job/settings.cpp).
  std::string pacing = setting("present.pacing").default_value().get<std::string>();
  int buffers = setting("present.buffers").default_value().get<int>();

  static const job::Setting& setting(std::string_view path) { return *job::find_setting(path); }
};

nlohmann::json result_json(const PresentResult& r) {
  nlohmann::json meta = nullptr;
  if (r.hdr_metadata) {
    const auto bytes = serialize(*r.hdr_metadata);
    std::string hex;
    for (auto b : bytes) hex += fmt::format("{:02x}", b);
    meta = {{"eotf", static_cast<int>(r.hdr_metadata->eotf)},
            {"max_display_mastering_luminance", r.hdr_metadata->max_display_mastering_luminance},
            {"min_display_mastering_luminance", r.hdr_metadata->min_display_mastering_luminance},
            {"max_cll", r.hdr_metadata->max_cll},
            {"max_fall", r.hdr_metadata->max_fall},
            {"blob_hex", hex}};
  }
  return {{"device", r.device},
          {"connector", r.connector},
          {"mode", {{"width", r.mode.hdisplay}, {"height", r.mode.vdisplay}, {"refresh_hz", r.mode.refresh_hz()}}},
          {"crtc_id", r.crtc_id},
          {"plane_id", r.plane_id},
          {"fb_id", r.fb_id},
          {"fourcc", fourcc_name(r.fourcc)},
          {"signal", std::string(to_string(r.signal))},
          {"colorspace", r.colorspace},
          {"hdr_output_metadata", meta},
          {"max_bpc", r.max_bpc ? nlohmann::json(*r.max_bpc) : nlohmann::json(nullptr)},
          {"committed", r.committed},
          {"notes", r.notes}};
}

std::string result_text(const PresentResult& r) {
  std::string s = fmt::format("{} on {} {}: {}x{} @ {:.3f} Hz, {} {}{}\n", r.committed ? "showing" : "TEST_ONLY passed",
                              r.device, r.connector, r.mode.hdisplay, r.mode.vdisplay, r.mode.refresh_hz(),
                              to_string(r.signal), fourcc_name(r.fourcc),
                              r.colorspace.empty() ? "" : ", Colorspace " + r.colorspace);
  if (r.hdr_metadata)
    s += fmt::format("HDR_OUTPUT_METADATA: EOTF {}, mastering {}/{} (x0.0001) cd/m2, MaxCLL {}, MaxFALL {}\n",
                     static_cast<int>(r.hdr_metadata->eotf), r.hdr_metadata->max_display_mastering_luminance,
                     r.hdr_metadata->min_display_mastering_luminance, r.hdr_metadata->max_cll, r.hdr_metadata->max_fall);
  for (const auto& n : r.notes) s += "note: " + n + "\n";
  return s;
}

PresentOptions present_options(const PresentCliOptions& o) {
  PresentOptions opt;
  opt.connector = o.connector;
  opt.test_only = o.test_only;
  const auto policy = parse_scrgb_policy(o.scrgb);
  if (!policy) throw CliError("--scrgb: '" + o.scrgb + "' is not convert, refuse or passthrough");
  opt.scrgb = *policy;
  return opt;
}

void run_still(const PresentCliOptions& o, const std::string& sidecar) {
  const PresentOptions opt = present_options(o);
  if (!(o.seconds >= 0)) throw CliError("--seconds must be >= 0");
  auto frame = read_dump(sidecar);
  if (!frame) throw HdrdError(frame.error());
  Presenter presenter;
  auto r = presenter.show(*frame, opt, o.device);
  if (!r) throw HdrdError(r.error());
  print_out(o.common.json ? result_json(*r).dump(2) : result_text(*r));
  if (r->committed && o.seconds > 0) {
    progress("holding the frame for {:g} s", o.seconds);
    std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  }
  presenter.close();
}

nlohmann::json stats_json(const SequenceStats& s) {
  return {{"frames_in", s.frames_in},
          {"frames_shown", s.frames_shown},
          {"frames_dropped", s.frames_dropped},
          {"frames_late", s.frames_late},
          {"flips", s.flips},
          {"repeats", s.repeats},
          {"fps_target", s.fps_target},
          {"refresh_hz", s.refresh_hz},
          {"measured_refresh_hz", s.measured_refresh_hz},
          {"measured_fps", s.measured_fps},
          {"frame_interval_ms", {{"mean", s.frame_interval_ms_mean}, {"min", s.frame_interval_ms_min},
                                 {"max", s.frame_interval_ms_max}}},
          {"elapsed_s", s.elapsed_s},
          {"cancelled", s.cancelled}};
}

// Ctrl-C / SIGTERM: the presenter stops at the next frame and turns the display off.
std::atomic<SequencePresenter*> g_presenter{nullptr};
extern "C" void on_stop_signal(int) {
  if (SequencePresenter* p = g_presenter.load()) p->cancel();
}

struct SignalGuard {
  explicit SignalGuard(SequencePresenter& p) {
    g_presenter.store(&p);
    old_int = std::signal(SIGINT, on_stop_signal);
    old_term = std::signal(SIGTERM, on_stop_signal);
  }
  ~SignalGuard() {
    std::signal(SIGINT, old_int);
    std::signal(SIGTERM, old_term);
    g_presenter.store(nullptr);
  }
  void (*old_int)(int) = nullptr;
  void (*old_term)(int) = nullptr;
};

// One line on stderr, rewritten in place on a terminal at most 5 times a second.
class ProgressLine {
 public:
  explicit ProgressLine(std::size_t total) : total_(total), tty_(isatty(2) && progress_enabled()) {}
  void update(const SequenceStats& s, bool last = false) {
    const auto now = std::chrono::steady_clock::now();
    if (!tty_ || (!last && now - shown_ < std::chrono::milliseconds(200))) return;
    shown_ = now;
    std::fprintf(stderr, "\rhdrd: frame %llu/%zu  %.2f fps (target %.3g)  dropped %llu  late %llu%s",
                 static_cast<unsigned long long>(s.frames_in), total_, s.measured_fps, s.fps_target,
                 static_cast<unsigned long long>(s.frames_dropped), static_cast<unsigned long long>(s.frames_late),
                 last ? "\n" : "");
  }

 private:
  std::size_t total_;
  bool tty_;
  std::chrono::steady_clock::time_point shown_{};
};

void run_sequence(const PresentCliOptions& o) {
  SequenceOptions so;
  so.present = present_options(o);
  if (o.fps < 0 || o.fps > 1000) throw CliError("--fps must be between 0 (the mode's refresh rate) and 1000");
  const auto pacing = parse_pacing(o.pacing);
  if (!pacing) throw CliError("--pacing: '" + o.pacing + "' is not realtime or every-frame");
  const auto& buffers = PresentCliOptions::setting("present.buffers");
  if (o.buffers < buffers.min || o.buffers > buffers.max)
    throw CliError(fmt::format("--buffers must be between {} and {}", buffers.min, buffers.max));
  auto seq = open_dump_sequence(o.inputs);
  if (!seq) throw HdrdError(seq.error());
  if (o.test_only) return run_still(o, seq->sidecars.front().string());  // the configuration of the first frame
  so.pacing = *pacing;
  so.buffers = o.buffers;
  so.fps = o.fps > 0 ? o.fps : seq->fps.value_or(0);
  so.content_light = seq->content_light;
  auto presenter = open_sequence_presenter(so, o.device);
  if (!presenter) throw HdrdError(presenter.error());

  // One frame read ahead on a second thread, so reading overlaps the flips; memory stays
  // at the presenter's buffers plus two frames.
  const auto& files = seq->sidecars;
  std::size_t next = 0;
  std::future<Result<EncodedFrame>> ahead;
  auto read_ahead = [&] {
    if (next < files.size()) ahead = std::async(std::launch::async, [p = files[next]] { return read_dump(p); });
  };
  read_ahead();
  FrameSource source = [&]() -> std::optional<Result<EncodedFrame>> {
    if (next >= files.size()) return std::nullopt;
    Result<EncodedFrame> f = ahead.get();
    ++next;
    read_ahead();
    return f;
  };
  ProgressLine line(files.size());
  SignalGuard guard(**presenter);
  auto r = present_sequence(**presenter, source, [&](const SequenceStats& s) { line.update(s); });
  if (ahead.valid()) ahead.wait();
  if (!r) throw HdrdError(r.error());
  line.update(r->stats, true);
  if (o.common.json) {
    nlohmann::json j = {{"setup", result_json(r->setup)},
                        {"frames", files.size()},
                        {"first_frame", files.front().string()},
                        {"pacing", std::string(to_string(so.pacing))},
                        {"buffers", so.buffers},
                        {"content_light_level", {{"max_cll_nits", so.content_light->max_cll_nits},
                                                 {"max_fall_nits", so.content_light->max_fall_nits}}},
                        {"stats", stats_json(r->stats)}};
    print_out(j.dump(2));
    return;
  }
  const SequenceStats& s = r->stats;
  print_out(result_text(r->setup) +
            fmt::format("{} {} of {} frames at {:.3f} fps (target {:.3f}, {} pacing, {} buffers): {} dropped, {} late, "
                        "{} repeats; frame interval {:.2f} ms (min {:.2f}, max {:.2f}); refresh {:.3f} Hz measured, "
                        "{:.3f} Hz mode\n",
                        s.cancelled ? "cancelled after showing" : "showed", s.frames_shown, files.size(), s.measured_fps,
                        s.fps_target, to_string(so.pacing), so.buffers, s.frames_dropped, s.frames_late, s.repeats,
                        s.frame_interval_ms_mean, s.frame_interval_ms_min, s.frame_interval_ms_max,
                        s.measured_refresh_hz, s.refresh_hz));
}

void run(const PresentCliOptions& o) {
  set_progress_enabled(!o.common.quiet);
  if (names_a_dump_sequence(o.inputs)) return run_sequence(o);
  run_still(o, o.inputs.front());
}

void setup(CLI::App& root) {
  auto o = std::make_shared<PresentCliOptions>();
  auto* app = root.add_subcommand("present", "Show a raw dump, or a sequence of them, on a display via KMS");
  app->add_option("dumps", o->inputs,
                  "A dump's JSON sidecar (out/desk.json, from 'hdrd encode --format raw'), or a sequence: "
                  "a pattern (out/shot.%05d.json), a directory, a list file, the sequence sidecar, or several sidecars")
      ->required();
  app->add_option("--device", o->device, "DRM card node (default: every /dev/dri/card* in turn)");
  app->add_option("--connector", o->connector, "Connector name, e.g. HDMI-A-1 (default: the first connected)");
  app->add_option("--seconds", o->seconds, "How long to keep a single frame on screen")->capture_default_str();
  app->add_option("--fps", o->fps, "Sequence frame rate (default: the sequence sidecar's, else the mode's refresh rate)");
  app->add_option("--pacing", o->pacing, std::string(PresentCliOptions::setting("present.pacing").doc))
      ->capture_default_str();
  app->add_option("--buffers", o->buffers, std::string(PresentCliOptions::setting("present.buffers").doc))
      ->capture_default_str();
  app->add_option("--scrgb", o->scrgb, "scRGB frames: convert (to HDR10), refuse, or passthrough (raw FP16)")
      ->capture_default_str();
  app->add_flag("--test-only", o->test_only, "Only check the configuration (atomic TEST_ONLY commit)");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd encode Desk.exr -o out/desk --mode hdr10 --format raw && hdrd present out/desk.json\n"
      "  hdrd present out/desk.json --connector DP-1 --seconds 30\n"
      "  hdrd present out/desk.json --test-only --json\n"
      "  hdrd render --scene hdr --frames 240 --fps 24 --format raw -o out/walk && hdrd present out/walk.json\n"
      "  hdrd present 'out/walk.%05d.json' --fps 24 --json\n"
      "Needs DRM master (run from a text console, not under a compositor). HDR signals set\n"
      "HDR_OUTPUT_METADATA and Colorspace BT2020_RGB; scRGB is converted to HDR10 by default.\n"
      "A sequence is shown with page flips at the frame rate; HDR_OUTPUT_METADATA carries the\n"
      "whole sequence's MaxCLL/MaxFALL; Ctrl-C stops it and turns the display off.\n"
      "Without a display it exits 1 with 'no display attached'.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("present", 62, &hdrd::cli::setup)

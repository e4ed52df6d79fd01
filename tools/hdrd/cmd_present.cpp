// hdrd present OUTBASE.json: show a raw dump on a display through KMS (atomic commit,
// HDR_OUTPUT_METADATA, Colorspace), or say clearly that no display is attached.
#include <chrono>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/dump_reader.hpp"
#include "display/presenter.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

using namespace hdrd::display;

struct PresentCliOptions {
  CommonOptions common;
  std::string sidecar;
  std::string device;
  std::string connector;
  std::string scrgb = "convert";
  double seconds = 10;
  bool test_only = false;
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

void run(const PresentCliOptions& o) {
  set_progress_enabled(!o.common.quiet);
  PresentOptions opt;
  opt.connector = o.connector;
  opt.test_only = o.test_only;
  const auto policy = parse_scrgb_policy(o.scrgb);
  if (!policy) throw CliError("--scrgb: '" + o.scrgb + "' is not convert, refuse or passthrough");
  opt.scrgb = *policy;
  if (!(o.seconds >= 0)) throw CliError("--seconds must be >= 0");

  auto frame = read_dump(o.sidecar);
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

void setup(CLI::App& root) {
  auto o = std::make_shared<PresentCliOptions>();
  auto* app = root.add_subcommand("present", "Show a raw dump (OUTBASE.json + OUTBASE.raw) on a display via KMS");
  app->add_option("sidecar", o->sidecar, "The dump's JSON sidecar, e.g. out/desk.json (written by 'hdrd encode')")
      ->required();
  app->add_option("--device", o->device, "DRM card node (default: every /dev/dri/card* in turn)");
  app->add_option("--connector", o->connector, "Connector name, e.g. HDMI-A-1 (default: the first connected)");
  app->add_option("--seconds", o->seconds, "How long to keep the frame on screen")->capture_default_str();
  app->add_option("--scrgb", o->scrgb, "scRGB frames: convert (to HDR10), refuse, or passthrough (raw FP16)")
      ->capture_default_str();
  app->add_flag("--test-only", o->test_only, "Only check the configuration (atomic TEST_ONLY commit)");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd encode Desk.exr -o out/desk --mode hdr10 --format raw && hdrd present out/desk.json\n"
      "  hdrd present out/desk.json --connector DP-1 --seconds 30\n"
      "  hdrd present out/desk.json --test-only --json\n"
      "Needs DRM master (run from a text console, not under a compositor). HDR signals set\n"
      "HDR_OUTPUT_METADATA and Colorspace BT2020_RGB; scRGB is converted to HDR10 by default.\n"
      "Without a display it exits 1 with 'no display attached'.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("present", 62, &hdrd::cli::setup)

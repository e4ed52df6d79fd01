// hdrd edid FILE.bin: everything hdrd reads from an EDID, and the display profile it
// derives (docs/displays.md). Text output follows edid-decode's layout for the parsed
// fields; --json prints the keys docs/displays.md lists.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/displays.hpp"
#include "display/edid.hpp"
#include "display/edid_json.hpp"
#include "display/profile.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

using namespace hdrd::display;

struct EdidOptions {
  CommonOptions common;
  std::string file;
  std::string profile_file;
  bool no_overrides = false;
};

std::string xy_text(color::Chromaticity c) { return fmt::format("({:.4f}, {:.4f})", c.x, c.y); }

std::string summary_text(const EdidInfo& e, const Profile& p) {
  std::string s = "\nhdrd:\n";
  s += fmt::format("  Name: '{}' ({} {} / 0x{:04X})\n", e.name, e.manufacturer, e.product_code, e.product_code);
  if (const auto* t = e.preferred_timing())
    s += fmt::format("  Preferred timing: {}x{}{} @ {:.3f} Hz\n", t->h_active, t->v_active, t->interlaced ? "i" : "",
                     t->refresh_hz());
  if (e.hdr_static_metadata) {
    const auto& h = *e.hdr_static_metadata;
    s += fmt::format("  HDR static metadata: {}\n", h.location);
    auto lum = [](const char* what, const std::optional<std::uint8_t>& cv, const std::optional<double>& nits) {
      return cv ? fmt::format("    {}: CV {} = {:.3f} cd/m2\n", what, *cv, *nits) : fmt::format("    {}: not given\n", what);
    };
    s += lum("max", h.max_luminance_cv, h.max_luminance_cd_m2());
    s += lum("max frame-average", h.max_frame_avg_luminance_cv, h.max_frame_avg_luminance_cd_m2());
    s += lum("min", h.min_luminance_cv, h.min_luminance_cd_m2());
  } else {
    s += "  HDR static metadata: none\n";
  }
  s += fmt::format("  Colorimetry: {}\n",
                   e.colorimetry ? fmt::format("{}", fmt::join(colorimetry_names(*e.colorimetry), " ")) : "none");
  s += fmt::format("  HDR10+ VSVDB: {}, Dolby Vision VSVDB: {}\n", e.hdr10plus_vsvdb ? "yes" : "no",
                   e.dolby_vision_vsvdb ? "yes" : "no");
  s += "Profile:\n";
  s += fmt::format("  mode {}: {}\n", to_string(p.mode), p.mode_reason);
  s += fmt::format("  peak {:.3f} cd/m2, frame-average {:.3f} cd/m2, black {:.4f} cd/m2\n", p.peak_nits,
                   p.frame_average_nits, p.black_nits);
  s += fmt::format("  primaries R {} G {} B {} W {}\n", xy_text(p.primaries.red), xy_text(p.primaries.green),
                   xy_text(p.primaries.blue), xy_text(p.primaries.white));
  for (const auto& n : p.notes) s += fmt::format("  note: {}\n", n);
  s += e.warnings.empty() ? "Warnings: none\n" : "Warnings:\n";
  for (const auto& w : e.warnings) s += fmt::format("  - {}\n", w);
  return s;
}

void run(const EdidOptions& o) {
  auto bytes = read_binary_file(o.file);
  if (!bytes) throw HdrdError(bytes.error());
  auto info = parse_edid(*bytes);
  if (!info) {
    Error e = info.error();
    e.message = o.file + ": " + e.message;
    throw HdrdError(e);
  }
  Profile profile = profile_from_edid_info(*info);
  if (!o.no_overrides) {
    auto overrides = load_default_overrides();
    if (!overrides) throw HdrdError(overrides.error());
    auto applied = apply_matching_overrides(profile, *overrides);
    if (!applied) throw HdrdError(applied.error());
    profile = std::move(*applied);
  }
  if (!o.profile_file.empty()) {
    auto ov = load_profile_override(o.profile_file);
    if (!ov) throw HdrdError(ov.error());
    auto applied = apply_override(profile, *ov);
    if (!applied) throw HdrdError(applied.error());
    profile = std::move(*applied);
  }
  if (o.common.json) {
    nlohmann::json j = edid_to_json(*info);
    j["file"] = o.file;
    j["profile"] = profile_to_json(profile);
    print_out(j.dump(2));
  } else {
    print_out(format_edid_text(*info) + summary_text(*info, profile));
  }
}

void setup(CLI::App& root) {
  auto o = std::make_shared<EdidOptions>();
  auto* app = root.add_subcommand("edid", "Decode an EDID file and show the display profile hdrd derives from it");
  app->add_option("file", o->file, "EDID blob (128-32768 bytes), e.g. /sys/class/drm/card0-HDMI-A-1/edid")->required();
  app->add_option("--profile", o->profile_file, "Apply this profile override file (.toml/.json) to the profile");
  app->add_flag("--no-overrides", o->no_overrides, "Ignore override files in the profile directories");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd edid /sys/class/drm/card0-DP-1/edid\n"
      "  hdrd edid ../shared/fixtures/edid/DELA0EA_29633DC619A6.bin --json\n"
      "  hdrd edid monitor.bin --profile config/profiles/dell-u2718q.toml\n"
      "The text follows edid-decode's layout for the fields hdrd parses; see docs/displays.md\n"
      "for the JSON keys and how the profile's mode and luminance are chosen.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("edid", 60, &hdrd::cli::setup)

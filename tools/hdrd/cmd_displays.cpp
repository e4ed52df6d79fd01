// hdrd displays: the DRM devices' connectors, their modes, HDR properties and profiles.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/displays.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

using namespace hdrd::display;

struct DisplaysOptions {
  CommonOptions common;
  bool all = false;
};

std::string connector_text(const ConnectorReport& c) {
  std::string s = fmt::format("{} {} ({}, {}):", c.device, c.connector.name, c.driver, to_string(c.connector.status));
  if (!c.connected()) return s + "\n";
  s += "\n";
  for (const auto& m : c.connector.modes)
    if (m.preferred()) s += fmt::format("  preferred mode {}x{} @ {:.3f} Hz ({} modes)\n", m.hdisplay, m.vdisplay, m.refresh_hz(), c.connector.modes.size());
  s += fmt::format("  HDR_OUTPUT_METADATA: {}; Colorspace: {}; max bpc: {}\n", c.has_hdr_output_metadata ? "yes" : "no",
                   c.colorspaces.empty() ? "absent" : fmt::format("{}", fmt::join(c.colorspaces, " ")),
                   c.max_bpc ? fmt::format("{} (range {}-{})", *c.max_bpc, c.max_bpc_range->first, c.max_bpc_range->second)
                             : "absent");
  if (c.edid) s += fmt::format("  EDID: '{}' {} {}\n", c.edid->name, c.edid->manufacturer, c.edid->product_code);
  if (c.edid_error) s += fmt::format("  EDID: {}\n", *c.edid_error);
  if (c.profile) {
    const auto& p = *c.profile;
    s += fmt::format("  profile: {} peak {:.1f} / frame-average {:.1f} / black {:.4f} cd/m2 ({})\n", to_string(p.mode),
                     p.peak_nits, p.frame_average_nits, p.black_nits, p.mode_reason);
    for (const auto& n : p.notes) s += fmt::format("    note: {}\n", n);
  }
  s += fmt::format("  HDR output possible: {}\n", c.hdr_capable() ? "yes" : "no");
  return s;
}

void run(const DisplaysOptions& o) {
  auto overrides = load_default_overrides();
  if (!overrides) throw HdrdError(overrides.error());
  const DisplaysReport report = enumerate_displays(*overrides);
  if (o.common.json) {
    print_out(to_json(report).dump(2));
    return;
  }
  std::string s;
  if (report.devices.empty()) {
    print_out("No displays: " + report.note);
    return;
  }
  for (const auto& c : report.connectors)
    if (o.all || c.connected()) s += connector_text(c);
  for (const auto& e : report.errors) s += "error: " + e + "\n";
  if (!report.note.empty()) s += report.note + "\n";
  print_out(s);
}

void setup(CLI::App& root) {
  auto o = std::make_shared<DisplaysOptions>();
  auto* app = root.add_subcommand("displays", "List connected displays (DRM connectors), their HDR support and profiles");
  app->add_flag("-a,--all", o->all, "Also list disconnected connectors (the JSON always lists all)");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd displays\n"
      "  hdrd displays --json | jq '.connectors[] | select(.hdr_capable)'\n"
      "On a machine without DRM devices (headless) it prints that no display is attached\n"
      "and exits 0; the JSON then has empty 'devices' and 'connectors' and a 'note'.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("displays", 61, &hdrd::cli::setup)

// hdrd selftest --mode M [--peak P]: the display-mode suite (docs/display-modes.md).
// Exit status 0 when every check passes, 1 otherwise; --json prints the report.
#include <cstdlib>

#include "patterns/selftest.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct SelftestOptions {
  CommonOptions common;
  std::string mode = "hdr10";
  std::optional<double> peak_nits;
  bool no_render = false;
  bool failed_only = false;
};

std::string report_text(const patterns::Report& r, bool failed_only) {
  std::string s = fmt::format("selftest {} (peak {} cd/m2, paper white {} cd/m2): {} checks, {} failed, {:.1f} s\n",
                              r.mode, r.target.peak_nits, r.target.paper_white_nits, r.checks.size(),
                              r.failed_count(), r.seconds);
  for (const auto& c : r.checks) {
    if (failed_only && (c.passed || c.skipped)) continue;
    const char* status = c.skipped ? "SKIP" : (c.passed ? "ok  " : "FAIL");
    s += fmt::format("  {} {:34} {}  [{}]\n", status, c.name, c.detail, c.source);
  }
  return s;
}

void run(const SelftestOptions& o) {
  set_progress_enabled(!o.common.quiet);
  auto target = patterns::suite_target(o.mode, o.peak_nits);
  if (!target) throw HdrdError(target.error());
  patterns::SuiteOptions so;
  so.render = !o.no_render;
  progress("running the display-mode suite for {}", o.mode);
  const patterns::Report r = patterns::run_suite(*target, o.mode, so);
  print_out(o.common.json ? r.to_json().dump(2) : report_text(r, o.failed_only));
  if (!r.passed()) {
    std::fflush(stdout);
    std::exit(1);  // the report is the output; no extra error line
  }
}

void setup(CLI::App& root) {
  auto o = std::make_shared<SelftestOptions>();
  auto* app = root.add_subcommand("selftest", "Run the display-mode suite for one mode and report every check");
  app->add_option("--mode", o->mode, "Display mode: " + patterns::suite_modes_text())->capture_default_str();
  app->add_option("--peak", o->peak_nits, "Display peak luminance, cd/m2 (default: the mode's)");
  app->add_flag("--no-render", o->no_render, "Skip the rendered built-in scenes");
  app->add_flag("--failed", o->failed_only, "Print only failed checks (text output)");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd selftest --mode hdr10 --peak 1000\n"
      "  hdrd selftest --mode hlg --json\n"
      "  hdrd selftest --mode sdr-bt1886 --failed\n"
      "Exit status 1 when a check fails. Checks and their sources: docs/display-modes.md.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("selftest", 45, &hdrd::cli::setup)

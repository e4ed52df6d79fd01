// hdrd settings: every request setting (job/settings.hpp) — its JSON path, CLI flag, query
// parameter, type, unit, range, default and meaning — as text, JSON or the Markdown table of
// docs/settings.md.
#include <fmt/format.h>

#include "job/settings.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct SettingsOptions {
  CommonOptions common;
  bool markdown = false;
};

void run(const SettingsOptions& o) {
  if (o.common.json) return print_out(job::settings_json().dump(2));
  if (o.markdown) return print_out(job::settings_markdown());
  std::string s;
  for (const auto& e : job::settings()) {
    std::string where = e.flag.empty() ? std::string("(API only)") : std::string(e.flag);
    if (e.reach == job::Reach::cli) where += " (CLI only)";
    s += fmt::format("{:34} {:22} {}; default: {}\n", e.path, where, e.doc, e.default_text());
  }
  print_out(s);
}

void setup(CLI::App& root) {
  auto o = std::make_shared<SettingsOptions>();
  auto* app = root.add_subcommand("settings", "List every request setting: JSON path, CLI flag, range, default");
  app->add_flag("--markdown", o->markdown, "The table of docs/settings.md");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd settings\n"
      "  hdrd settings --json | jq '.[] | select(.path | startswith(\"display.\"))'\n"
      "  hdrd settings --markdown > table.md\n"
      "The same table drives hdrd render/encode/pattern, hdrctl and the daemon's request parser.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("settings", 60, &hdrd::cli::setup)

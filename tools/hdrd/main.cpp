// hdrd: one program, many subcommands (see command.hpp for how they register).
#include <algorithm>
#include <cstdio>
#include <exception>

#include "encode/grade/ocio.hpp"
#include "encode/result.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {

std::vector<CommandSpec>& commands() {
  static std::vector<CommandSpec> list;
  return list;
}

bool register_command(CommandSpec spec) {
  commands().push_back(spec);
  return true;
}

namespace {
bool g_progress = true;
}
bool progress_enabled() { return g_progress; }
void set_progress_enabled(bool on) { g_progress = on; }

void add_common_options(CLI::App& app, CommonOptions& o) {
  app.add_flag("--json", o.json, "Print machine-readable JSON on stdout");
  app.add_flag("-q,--quiet", o.quiet, "No progress on stderr");
}

void print_out(const std::string& text) {
  std::fwrite(text.data(), 1, text.size(), stdout);
  if (text.empty() || text.back() != '\n') std::fputc('\n', stdout);
  std::fflush(stdout);
}

}  // namespace hdrd::cli

int main(int argc, char** argv) {
  using namespace hdrd::cli;
  // OpenColorIO's ACES output transforms join the tone-curve registry (aces-ocio-*).
  hdrd::ocio::register_tone_curves();
  CLI::App app{"hdrd: headless HDR display-output service (render, encode, inspect displays)", "hdrd"};
  app.require_subcommand(1);
  app.set_version_flag("--version", HDRD_VERSION_STRING);
  app.footer(
      "Examples:\n"
      "  hdrd encode ../shared/fixtures/exr/Desk.exr -o out/desk --mode hdr10 --peak 1000\n"
      "  hdrd render --scene material-grid -o out/grid --mode sdr\n"
      "  hdrd edid monitor.bin --json\n"
      "Run 'hdrd SUBCOMMAND --help' for the options and examples of each subcommand.");
  auto specs = commands();
  std::sort(specs.begin(), specs.end(), [](const CommandSpec& a, const CommandSpec& b) { return a.order < b.order; });
  for (const auto& s : specs) s.setup(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "hdrd: error: %s (see --help)\n", e.what());
    return 2;
  } catch (const hdrd::HdrdError& e) {
    const auto& err = e.error();
    std::fprintf(stderr, "hdrd: error: %s\n", err.message.c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hdrd: error: %s\n", e.what());
    return 1;
  }
  return 0;
}

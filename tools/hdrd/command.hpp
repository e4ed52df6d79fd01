// The hdrd subcommand registry. Each subcommand lives in its own cmd_<name>.cpp,
// registers itself with HDRD_REGISTER_COMMAND, and reports failure by throwing
// (hdrd::HdrdError or CliError); main() turns that into one line and exit code 1.
#pragma once

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace hdrd::cli {

struct CommandSpec {
  const char* name;
  int order;                    // position in `hdrd --help`
  void (*setup)(CLI::App& root);  // adds the subcommand, its options and callback
};

std::vector<CommandSpec>& commands();
bool register_command(CommandSpec spec);

// A user error that is not a Result error (bad option combinations, missing files).
class CliError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Options every subcommand shares.
struct CommonOptions {
  bool json = false;
  bool quiet = false;
};
void add_common_options(CLI::App& app, CommonOptions& o);

// Progress and timing for long work, on stderr (never stdout, which carries results).
bool progress_enabled();
void set_progress_enabled(bool on);
template <class... Args>
void progress(fmt::format_string<Args...> f, Args&&... args) {
  if (!progress_enabled()) return;
  std::fputs(("hdrd: " + fmt::format(f, std::forward<Args>(args)...) + "\n").c_str(), stderr);
}

// Prints a JSON document (already serialised) or human text to stdout.
void print_out(const std::string& text);

}  // namespace hdrd::cli

#define HDRD_CONCAT_INNER(a, b) a##b
#define HDRD_CONCAT(a, b) HDRD_CONCAT_INNER(a, b)
#define HDRD_REGISTER_COMMAND(name, order, setup_fn)                          \
  namespace {                                                                \
  [[maybe_unused]] const bool HDRD_CONCAT(hdrd_registered_, __LINE__) =       \
      ::hdrd::cli::register_command({name, order, setup_fn});                \
  }

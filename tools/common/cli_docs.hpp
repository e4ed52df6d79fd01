// Man pages and bash completions written from a program's CLI11 tree — the same options,
// help texts and choices `--help` shows, which for the request options are the settings
// table's (settings_cli.hpp) — so that they are one source with docs/settings.md. The build
// writes them with `hdrd docs ...` / `hdrctl docs ...` (a hidden subcommand; cmake/Docs.cmake)
// and tests/package checks them against `hdrd settings --json` and `hdrd serve --print-config`.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

namespace hdrd::cli {

// What the value of an option completes to: the words, and/or file names. An option with
// no hint completes file names when its value is text, nothing when it is a number.
struct ValueHint {
  std::vector<std::string> words{};
  bool files = false;
  bool list = false;  // a comma-separated list of the words (--format png,exr)
};
void set_value_hint(const CLI::Option* option, ValueHint hint);
const ValueHint* value_hint(const CLI::Option* option);
// Sets `hint` on every option named `flag` in the tree under `app` (e.g. --tonemap).
void set_value_hint_everywhere(CLI::App& app, std::string_view flag, const ValueHint& hint);

// A man page section the CLI tree has no text for (FILES, ENVIRONMENT, EXIT STATUS, ...).
struct ManSection {
  std::string title;
  std::string text;  // plain text; paragraphs separated by blank lines, "  " indents a line as is
};

struct ManPage {
  std::string name;     // "hdrd"
  int section = 1;
  std::string version;  // "hdrd 0.1.0"
  std::string summary;  // the NAME line's "name \- summary"
  std::vector<ManSection> sections{};   // after COMMANDS
  std::vector<std::string> see_also{};  // "hdrctl(1)"
};

// roff for `man`: NAME, SYNOPSIS, DESCRIPTION (the app's), OPTIONS, COMMANDS (every visible
// subcommand, nested ones as "hdrd sequence plan", each with its options and its examples),
// then `page.sections` and SEE ALSO.
std::string man_page(const CLI::App& app, const ManPage& page);

// A man page of key/value entries (hdrd.toml(5)): one .SS per section, one .TP per entry.
struct ManEntry {
  std::string heading;  // "[server]"
  std::string term;     // "socket_mode = \"0660\""
  std::string text;
};
std::string man_page_entries(const ManPage& page, std::string_view description, const std::vector<ManEntry>& entries,
                             std::string_view entries_title);

// Text escaped for roff: backslashes, leading dots and quotes, '-' as \-, non-ASCII as \[uXXXX].
std::string roff_escape(std::string_view text);

// A bash completion script for the program: `complete -F _NAME NAME`, completing
// subcommands, flags, the values of flags (hints, files) and positional files.
std::string bash_completion(const CLI::App& app);

}  // namespace hdrd::cli

// The settings table (job/settings.hpp) as CLI11 options: `hdrd render/encode/pattern` and
// `hdrctl render/encode/pattern` get the same flags, help and defaults from it, and hand
// what was typed to the one request parser (job::cli_to_request_json, then
// job::parse_request_json) — the CLI spells a request, it does not interpret one.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "encode/result.hpp"
#include "job/settings.hpp"

namespace hdrd::cli {

// What the user typed for settings: (flag, text) in the order the options were read.
struct SettingArgs {
  std::vector<std::pair<std::string, std::string>> given;
};

// Adds an option for every setting of `source` that has a flag and exists for `reach`,
// grouped as --help shows them (Display, Tone mapping, Exposure, ...), plus the composite
// flags (--camera, --ui-pos). `skip` names flags the caller defines itself.
void add_setting_options(CLI::App& app, job::Source source, job::Reach reach, SettingArgs& args,
                         const std::vector<std::string>& skip = {});

// The heading a setting is listed under in --help ("Display", "Environment", "Output", ...),
// by its path's first component; empty for a path no group claims (a test keeps every
// setting in one).
std::string_view setting_group(std::string_view path);

// A setting's --help line: its doc, unit, range or choices, default; a "--no-x" flag's says
// what it turns off.
std::string help_of(const job::Setting& s);

// The request JSON the typed flags stand for (errors name the flag).
Result<nlohmann::json> request_json(const SettingArgs& args);

}  // namespace hdrd::cli

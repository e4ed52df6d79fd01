// Which of the pattern settings (params.*, job/settings.hpp) each test pattern takes, and
// which modes it exists for: the request parser checks a pattern request against it and GET
// /v1/capabilities publishes it. Types, units and defaults are the settings table's. The
// patterns themselves are in patterns/ (hdrd_patterns); this table is kept with the pure
// request library so that its fuzz target need not link them. tests/job/request_test.cpp
// checks that its names are exactly the library's.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"

namespace hdrd::job {

struct PatternEntry {
  std::string_view name;
  std::span<const std::string_view> params;  // setting paths it takes ("params.level_nits")
  std::span<const Mode> modes;               // empty: every mode
  int min_steps = 0, max_steps = 0;          // params.steps, when it takes it
};

std::span<const PatternEntry> pattern_catalogue();
const PatternEntry* find_pattern_entry(std::string_view name);
bool takes_param(const PatternEntry& entry, std::string_view path);

// "bt2111, pq-ramp, window, ..." and "level_nits, labels" for error messages.
std::string pattern_names();
std::string param_names(const PatternEntry& entry);

// One entry of GET /v1/capabilities' "patterns" (description and source come from the
// pattern library and are added by the caller).
nlohmann::json pattern_entry_json(const PatternEntry& entry);

}  // namespace hdrd::job

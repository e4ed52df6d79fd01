// The test patterns POST /v1/pattern offers, with the parameters each one takes and their
// ranges: the request validator checks against this table and GET /v1/capabilities
// publishes it. The patterns themselves are in patterns/ (hdrd_patterns); this table is
// kept here so that the pure request library (and its fuzz target) need not link them.
// tests/daemon/request_test.cpp checks that its names are exactly the library's.
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"

namespace hdrd::daemon {

struct PatternParam {
  enum class Type { number, integer, boolean };
  std::string_view name;          // the key under "params"
  Type type;
  double min = 0, max = 0;        // numbers and integers
  std::optional<double> default_value;  // none: the default comes from the display (default_note)
  std::string_view default_note;  // "display.peak_nits" when the default is the display's peak
  std::string_view description;
};

struct PatternEntry {
  std::string_view name;
  std::span<const PatternParam> params;
  std::span<const Mode> modes;    // empty: every mode
};

std::span<const PatternEntry> pattern_catalogue();
const PatternEntry* find_pattern_entry(std::string_view name);
const PatternParam* find_param(const PatternEntry& entry, std::string_view name);

// "bt2111, pq-ramp, window, ..." and "level_nits, labels" for error messages.
std::string pattern_names();
std::string param_names(const PatternEntry& entry);

// One entry of GET /v1/capabilities' "patterns" (description and source come from the
// pattern library and are added by the caller).
nlohmann::json pattern_entry_json(const PatternEntry& entry);

}  // namespace hdrd::daemon

#include "job/pattern_params.hpp"

#include <algorithm>

#include "job/settings.hpp"

namespace hdrd::job {
namespace {

// What patterns/patterns.cpp draws: window and clipping at a level, ramps of steps,
// near-black's 10 fixed levels (docs/patterns.md).
constexpr std::string_view kRamp[] = {"params.steps", "params.labels"};
constexpr std::string_view kWindow[] = {"params.level_nits", "params.area_percent"};
constexpr std::string_view kClipping[] = {"params.level_nits", "params.labels"};
constexpr std::string_view kLabelsOnly[] = {"params.labels"};
// BT.2111-2 defines bars for PQ and HLG only.
constexpr Mode kBt2111Modes[] = {Mode::hdr10, Mode::hlg};
constexpr PatternEntry kPatterns[] = {
    {"bt2111", {}, kBt2111Modes},
    {"pq-ramp", kRamp, {}, 2, 256},
    {"window", kWindow, {}},
    {"near-black", kRamp, {}, 1, 10},
    {"clipping", kClipping, {}},
    {"sdr-grey", kRamp, {}, 2, 256},
    {"sdr-shadows", kLabelsOnly, {}},
};

std::string short_name(std::string_view path) { return std::string(path.substr(path.find('.') + 1)); }

}  // namespace

std::span<const PatternEntry> pattern_catalogue() { return kPatterns; }

const PatternEntry* find_pattern_entry(std::string_view name) {
  for (const auto& e : kPatterns)
    if (e.name == name) return &e;
  return nullptr;
}

bool takes_param(const PatternEntry& entry, std::string_view path) {
  return std::find(entry.params.begin(), entry.params.end(), path) != entry.params.end();
}

std::string pattern_names() {
  std::string s;
  for (const auto& e : kPatterns) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

std::string param_names(const PatternEntry& entry) {
  std::string s;
  for (const auto& p : entry.params) s += (s.empty() ? "" : ", ") + short_name(p);
  return s.empty() ? "none" : s;
}

nlohmann::json pattern_entry_json(const PatternEntry& entry) {
  nlohmann::json params = nlohmann::json::array();
  for (const auto path : entry.params) {
    const Setting* s = find_setting(path);
    nlohmann::json p = {{"name", short_name(path)}, {"type", to_string(s->type)}, {"description", s->doc},
                        {"default", s->default_value()}};
    if (!s->default_doc.empty()) p["default_from"] = s->default_doc;
    if (s->type == Type::number) p["min"] = s->min, p["max"] = s->max;
    if (path == "params.steps") p["min"] = entry.min_steps, p["max"] = entry.max_steps;
    params.push_back(std::move(p));
  }
  nlohmann::json modes = nlohmann::json::array();
  for (Mode m : entry.modes) modes.push_back(to_string(m));
  return {{"name", entry.name}, {"params", params}, {"modes", modes}};
}

}  // namespace hdrd::job

#include "daemon/pattern_catalogue.hpp"

#include <string>

namespace hdrd::daemon {
namespace {

using T = PatternParam::Type;

// Ranges follow what patterns/patterns.cpp accepts: levels within PQ's 10000 cd/m2, a
// window area in (0, 100] %, ramps of at least 2 steps, near-black's 10 fixed levels.
constexpr PatternParam kLevel{"level_nits", T::number, 1e-4, 10000, std::nullopt, "display.peak_nits",
                              "luminance of the window / the clipping point, cd/m2"};
constexpr PatternParam kArea{"area_percent", T::number, 0.01, 100, 10, "",
                             "window area in percent of the frame (1, 2, 10, 25, 50, 100 are the usual)"};
constexpr PatternParam kRampSteps{"steps", T::integer, 2, 256, 11, "", "number of steps"};
constexpr PatternParam kNearBlackSteps{"steps", T::integer, 1, 10, 10, "",
                                       "how many of the levels 0.005 .. 5 cd/m2 to show"};
constexpr PatternParam kLabels{"labels", T::boolean, 0, 1, 1, "", "draw the cd/m2 (or %) labels"};

constexpr PatternParam kPqRamp[] = {kRampSteps, kLabels};
constexpr PatternParam kWindow[] = {kLevel, kArea};
constexpr PatternParam kNearBlack[] = {kNearBlackSteps, kLabels};
constexpr PatternParam kClipping[] = {kLevel, kLabels};
constexpr PatternParam kSdrGrey[] = {kRampSteps, kLabels};
constexpr PatternParam kSdrShadows[] = {kLabels};
// BT.2111-2 defines bars for PQ and HLG only.
constexpr Mode kBt2111Modes[] = {Mode::hdr10, Mode::hlg};

constexpr PatternEntry kPatterns[] = {
    {"bt2111", {}, kBt2111Modes},
    {"pq-ramp", kPqRamp, {}},
    {"window", kWindow, {}},
    {"near-black", kNearBlack, {}},
    {"clipping", kClipping, {}},
    {"sdr-grey", kSdrGrey, {}},
    {"sdr-shadows", kSdrShadows, {}},
};

std::string_view type_name(T t) {
  switch (t) {
    case T::number: return "number";
    case T::integer: return "integer";
    case T::boolean: return "boolean";
  }
  return "number";
}

}  // namespace

std::span<const PatternEntry> pattern_catalogue() { return kPatterns; }

const PatternEntry* find_pattern_entry(std::string_view name) {
  for (const auto& e : kPatterns)
    if (e.name == name) return &e;
  return nullptr;
}

const PatternParam* find_param(const PatternEntry& entry, std::string_view name) {
  for (const auto& p : entry.params)
    if (p.name == name) return &p;
  return nullptr;
}

std::string pattern_names() {
  std::string s;
  for (const auto& e : kPatterns) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

std::string param_names(const PatternEntry& entry) {
  std::string s;
  for (const auto& p : entry.params) s += (s.empty() ? "" : ", ") + std::string(p.name);
  return s.empty() ? "none" : s;
}

nlohmann::json pattern_entry_json(const PatternEntry& entry) {
  nlohmann::json params = nlohmann::json::array();
  for (const auto& p : entry.params) {
    nlohmann::json j = {{"name", p.name}, {"type", type_name(p.type)}, {"description", p.description}};
    if (p.type == T::integer) j["min"] = static_cast<long long>(p.min), j["max"] = static_cast<long long>(p.max);
    else if (p.type == T::number) j["min"] = p.min, j["max"] = p.max;
    if (!p.default_value) j["default"] = nullptr;
    else if (p.type == T::boolean) j["default"] = *p.default_value != 0;
    else if (p.type == T::integer) j["default"] = static_cast<long long>(*p.default_value);
    else j["default"] = *p.default_value;
    if (!p.default_note.empty()) j["default_from"] = p.default_note;
    params.push_back(std::move(j));
  }
  nlohmann::json modes = nlohmann::json::array();
  for (Mode m : entry.modes) modes.push_back(to_string(m));
  if (entry.modes.empty())
    for (Mode m : {Mode::hdr10, Mode::hlg, Mode::scrgb, Mode::sdr, Mode::sdr_bt1886}) modes.push_back(to_string(m));
  return {{"name", entry.name}, {"params", params}, {"modes", modes}};
}

}  // namespace hdrd::daemon

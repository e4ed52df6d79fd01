#include "tools/common/settings_cli.hpp"

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

#include "encode/tone/tonemap.hpp"
#include "job/request.hpp"
#include "tools/common/cli_docs.hpp"

namespace hdrd::cli {
namespace {

// --help's headings, by a path's first component. Every setting has one (a test checks),
// so a new setting group is one line here, not a fallback heading.
struct SettingGroup {
  std::string_view head, title;
};
constexpr SettingGroup kSettingGroups[] = {
    {"display", "Display"},       {"tone", "Tone mapping"},     {"gamut", "Tone mapping"},
    {"gamut_target", "Tone mapping"},
    {"exposure", "Exposure"},     {"ui", "UI overlay"},         {"grade", "Grading"},
    {"scene", "Source"},          {"width", "Source"},          {"height", "Source"},
    {"samples", "Source"},        {"camera", "Source"},         {"start_s", "Source"},
    {"encoder", "Source"},        {"backend", "Source"},        {"input", "Source"},
    {"environment", "Environment"}, {"energy_compensation", "Environment"},
    {"gltf_emissive_nits", "Source"},
    {"pattern", "Pattern"},       {"params", "Pattern"},
    {"frames", "Sequence"},       {"fps", "Sequence"},          {"images", "Sequence"},
    {"sequence", "Sequence"},     {"video", "Sequence"},        {"metadata", "Sequence"},
    {"present", "Sequence"},
    {"formats", "Output"},        {"quality", "Output"},        {"lossless", "Output"},
    {"avif", "Output"},           {"jxl", "Output"},            {"jpeg", "Output"},
    {"gainmap", "Output"},        {"png_level", "Output"},      {"durable", "Output"},
    {"dither", "Output"},         {"dump", "Output"},           {"name", "Output"},
    {"timeout_s", "Output"},      {"threads", "Output"},
};


// A "--no-x" flag sets a default-true boolean false: its help says what it turns off, in the
// setting's own words ("Turn off params.labels (on by default): draw the cd/m2 labels"). A
// short lead that scopes the doc ("Sequences: ", "Preetham sky: ") stays in front.
std::string off_help(const job::Setting& s) {
  std::string_view doc = s.doc;
  std::string lead;
  if (const auto colon = doc.find(": "); colon != std::string_view::npos && colon <= 24 &&
                                         doc.substr(0, colon).find_first_of("(,;") == std::string_view::npos) {
    lead = std::string(doc.substr(0, colon + 2));
    doc.remove_prefix(colon + 2);
  }
  std::string what(doc);
  // "Draw the labels" -> "draw the labels"; an acronym ("GGX ...") keeps its case.
  if (what.size() > 1 && std::isupper(static_cast<unsigned char>(what[0])) &&
      !std::isupper(static_cast<unsigned char>(what[1])))
    what[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(what[0])));
  return fmt::format("{}{} {} (on by default): {}", lead, lead.empty() ? "Turn off" : "turn off", s.path, what);
}

}  // namespace

std::string_view setting_group(std::string_view path) {
  const std::string_view head = path.substr(0, path.find('.'));
  for (const auto& g : kSettingGroups)
    if (g.head == head) return g.title;
  return {};
}

std::string help_of(const job::Setting& s) {
  if (s.flag.rfind("--no-", 0) == 0) return off_help(s);
  std::string h(s.doc);
  std::string extra;
  if (!s.unit.empty()) extra = std::string(s.unit);
  if (s.type == job::Type::number || s.type == job::Type::integer)
    extra += fmt::format("{}[{:g}, {:g}]", extra.empty() ? "" : " ", s.min, s.max);
  if (s.type == job::Type::choice || s.type == job::Type::choice_list) {
    std::string c;
    for (auto v : s.choices) c += (c.empty() ? "" : ", ") + std::string(v);
    extra += (extra.empty() ? "" : "; ") + c;
  }
  extra += (extra.empty() ? "" : "; ") + std::string("default: ") + s.default_text();
  h += " (" + extra + ")";
  if (s.type == job::Type::number_map) h += "; repeatable";
  return h;
}

namespace {

// What the option's value completes to (bash completion, cli_docs.hpp).
ValueHint hint_of(const job::Setting& s) {
  ValueHint h;
  for (auto c : s.choices) h.words.emplace_back(c);
  h.list = s.type == job::Type::choice_list;
  h.files = s.type == job::Type::path || s.type == job::Type::scene;
  if (s.path == "tone.curve")
    for (const auto& c : tonemap::curves()) h.words.emplace_back(c.name);
  return h;
}

}  // namespace

void add_setting_options(CLI::App& app, job::Source source, job::Reach reach, SettingArgs& args,
                         const std::vector<std::string>& skip) {
  auto skipped = [&](std::string_view f) { return std::find(skip.begin(), skip.end(), f) != skip.end(); };
  for (const auto& s : job::settings()) {
    if (s.flag.empty() || !s.takes(source) || skipped(s.flag)) continue;
    if (s.reach != job::Reach::everywhere && s.reach != reach) continue;
    const std::string flag(s.flag);
    CLI::Option* o = nullptr;
    if (s.type == job::Type::boolean) {
      o = app.add_flag_callback(flag, [&args, flag] { args.given.emplace_back(flag, ""); }, help_of(s));
    } else {
      o = app.add_option(
          flag,
          [&args, flag](const CLI::results_t& res) {
            for (const auto& v : res) args.given.emplace_back(flag, v);
            return true;
          },
          help_of(s));
      o->type_name(std::string(s.metavar.empty() ? "VALUE" : s.metavar))->expected(1);
      o->multi_option_policy(s.type == job::Type::number_map ? CLI::MultiOptionPolicy::TakeAll
                                                             : CLI::MultiOptionPolicy::TakeLast);
    }
    o->group(std::string(setting_group(s.path)));
    set_value_hint(o, hint_of(s));
  }
  for (const auto& c : job::composites()) {
    if (!job::applies(c.sources, source) || skipped(c.flag)) continue;
    const std::string flag(c.flag);
    app.add_option(
           flag,
           [&args, flag](const CLI::results_t& res) {
             for (const auto& v : res) args.given.emplace_back(flag, v);
             return true;
           },
           std::string(c.doc))
        ->type_name(std::string(c.metavar))
        ->expected(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeLast)
        ->group(std::string(setting_group(c.paths[0])));
  }
}

Result<nlohmann::json> request_json(const SettingArgs& args) {
  // Composites first, so that a single flag (--camera-target) refines a composite (--camera).
  std::vector<std::pair<std::string, std::string>> ordered;
  for (const auto& a : args.given)
    for (const auto& c : job::composites())
      if (c.flag == a.first) ordered.push_back(a);
  for (const auto& a : args.given)
    if (std::none_of(job::composites().begin(), job::composites().end(), [&](const auto& c) { return c.flag == a.first; }))
      ordered.push_back(a);
  return job::cli_to_request_json(ordered);
}

}  // namespace hdrd::cli

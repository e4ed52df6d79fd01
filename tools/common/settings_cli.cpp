#include "tools/common/settings_cli.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "encode/tone/tonemap.hpp"
#include "job/request.hpp"
#include "tools/common/cli_docs.hpp"

namespace hdrd::cli {
namespace {

std::string group_of(std::string_view path) {
  const std::string_view head = path.substr(0, path.find('.'));
  if (head == "display") return "Display";
  if (head == "tone" || head == "gamut") return "Tone mapping";
  if (head == "exposure") return "Exposure";
  if (head == "ui") return "UI overlay";
  if (head == "grade") return "Grading";
  if (head == "params" || head == "pattern") return "Pattern";
  if (head == "frames" || head == "fps" || head == "start_s" || head == "images" || head == "video" ||
      head == "metadata" || head == "sequence")
    return "Sequence";
  if (head == "scene" || head == "width" || head == "height" || head == "samples" || head == "camera" ||
      head == "encoder" || head == "backend" || head == "input")
    return "Source";
  return "Output";
}

std::string help_of(const job::Setting& s) {
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
  if (s.flag.rfind("--no-", 0) != 0) extra += (extra.empty() ? "" : "; ") + std::string("default: ") + s.default_text();
  if (!extra.empty()) h += " (" + extra + ")";
  if (s.type == job::Type::number_map) h += "; repeatable";
  return h;
}

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
    o->group(group_of(s.path));
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
        ->group(group_of(c.paths[0]));
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

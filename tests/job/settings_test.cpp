// The settings table itself: one name, one flag, one query parameter, one default per
// setting; every default valid under its own rules; docs/settings.md generated from it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "job/outputs.hpp"
#include "job/request.hpp"
#include "job/settings.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::job {
namespace {

TEST(Settings, NamesFlagsQueriesAndHeadersAreUnique) {
  std::set<std::string_view> paths, flags, queries, headers;
  for (const auto& s : settings()) {
    EXPECT_TRUE(paths.insert(s.path).second) << s.path;
    if (!s.alias.empty()) {
      EXPECT_TRUE(paths.insert(s.alias).second) << s.alias;
    }
    if (!s.flag.empty()) {
      EXPECT_TRUE(flags.insert(s.flag).second) << s.flag;
    }
    if (!s.query.empty()) {
      EXPECT_TRUE(queries.insert(s.query).second) << s.query;
    }
    if (!s.header.empty()) {
      EXPECT_TRUE(headers.insert(s.header).second) << s.header;
    }
  }
  for (const auto& c : composites()) {
    EXPECT_TRUE(flags.insert(c.flag).second) << c.flag;
    for (auto p : c.paths) EXPECT_NE(find_setting(p), nullptr) << c.flag << " sets " << p;
  }
}

TEST(Settings, EachEntryIsComplete) {
  for (const auto& s : settings()) {
    SCOPED_TRACE(std::string(s.path));
    EXPECT_FALSE(s.doc.empty());
    EXPECT_EQ(s.doc.find('\n'), std::string_view::npos);
    EXPECT_GT(s.sources, 0u);
    if (!s.flag.empty()) {
      EXPECT_EQ(s.flag.rfind("--", 0), 0u);
    }
    if (s.type == Type::number || s.type == Type::integer) {
      EXPECT_LT(s.min, s.max);
    }
    if (s.type == Type::choice || s.type == Type::choice_list) {
      EXPECT_FALSE(s.choices.empty());
    }
    // Names carry units (REFERENCE.md §1.9; STYLE.md).
    if (s.path.ends_with("_nits")) {
      EXPECT_EQ(s.unit, "cd/m2");
    }
    if (s.path.ends_with("_ev")) {
      EXPECT_EQ(s.unit, "stops");
    }
    if (s.path.ends_with("_s")) {
      EXPECT_EQ(s.unit, "s");
    }
    // A default is either a value or a rule in words, never neither.
    const auto def = s.default_value();
    EXPECT_TRUE(!def.is_null() || !s.default_doc.empty());
    if (s.flag.rfind("--no-", 0) == 0) {
      EXPECT_EQ(def, true) << "a --no- flag turns a default true off";
    }
  }
}

// Every static default passes the setting's own validation: a request that says each
// default explicitly is accepted and means the same as one that says nothing. (Settings
// that refine an anchor — ui.* a UI PNG, grade.* a LUT, params.* a pattern's own — are
// refused without it by rule, so they are left out here and tested with their anchors.)
TEST(Settings, DefaultsPassTheirOwnRulesAndMeanNothingSaid) {
  for (Source source : {Source::render, Source::encode, Source::pattern})
  for (bool sequence : {false, true}) {
    if (sequence && source == Source::pattern) continue;
    SCOPED_TRACE(std::string(to_string(source)) + (sequence ? " sequence" : ""));
    nlohmann::json explicit_defaults = nlohmann::json::object();
    for (const auto& s : settings()) {
      if (!s.takes(source) || s.reach == Reach::cli || s.default_value().is_null()) continue;
      if (s.sequence && !sequence) continue;
      if (s.path.starts_with("ui.") || s.path.starts_with("grade.") || s.path.starts_with("params.")) continue;
      std::string p(s.path);
      std::replace(p.begin(), p.end(), '.', '/');
      explicit_defaults[nlohmann::json::json_pointer("/" + p)] = s.default_value();
    }
    ParseContext ctx;
    ctx.source = source;
    ctx.reach = Reach::daemon;
    ctx.sequence = sequence;
    nlohmann::json silent = nlohmann::json::object();
    if (source == Source::pattern) silent["pattern"] = explicit_defaults["pattern"] = "pq-ramp";
    auto a = parse_request_json(explicit_defaults, ctx);
    auto b = parse_request_json(silent, ctx);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_EQ(a->canonical(), b->canonical());
  }
}

TEST(Settings, FormatsAreTheOutputTable) {
  const auto* f = find_setting("formats");
  ASSERT_NE(f, nullptr);
  std::vector<std::string_view> names;
  for (const auto& o : outputs()) names.push_back(o.name);
  EXPECT_EQ(std::vector<std::string_view>(f->choices.begin(), f->choices.end()), names);
}

TEST(Settings, DocsTableIsGeneratedFromTheTable) {
  std::ifstream in(hdrd::testing::source_dir() / "docs/settings.md");
  ASSERT_TRUE(in) << "docs/settings.md";
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  const std::string table = settings_markdown();
  EXPECT_NE(doc.find(table), std::string::npos)
      << "docs/settings.md is out of date: regenerate its table with `hdrd settings --markdown`";
}

// Issue 29 item 11: docs/scene-format.md named `gltf_emissive_nits` as if it were a setting;
// it was not one. Every backticked name in docs/*.md that looks like a setting — a
// snake_case name ending in a unit (settings' names carry units: STYLE.md), or a dotted name
// under a setting group (`display.peak_nits`) — is a setting (its path, alias or last
// component, or a child of a map setting such as `tone.params.w`), or another name the
// program really reads or writes: a string literal in its sources (sidecar, scene and
// config keys), or one of the few C++ members the docs describe, listed here and checked to
// exist. docs/settings.md is the table itself.
TEST(Settings, EveryNameTheDocsGiveASettingIsOne) {
  namespace fs = std::filesystem;
  const fs::path root = hdrd::testing::source_dir();
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  std::set<std::string> names, heads, components, maps;
  for (const auto& st : settings()) {
    names.insert(std::string(st.path));
    if (!st.alias.empty()) names.insert(std::string(st.alias));
    const auto dot = st.path.rfind('.');
    components.insert(std::string(st.path.substr(dot == std::string_view::npos ? 0 : dot + 1)));
    if (st.path.find('.') != std::string_view::npos) heads.insert(std::string(st.path.substr(0, st.path.find('.'))));
    if (st.type == Type::number_map) maps.insert(std::string(st.path) + ".");
  }
  // String literals of the program's own sources (and its benchmarks'): the names it reads and writes.
  std::set<std::string> literals;
  const std::regex literal(R"re("([A-Za-z0-9_.]+)")re");
  std::string sources;
  for (const char* dir : {"bench", "daemon", "display", "encode", "job", "patterns", "shading", "tools", "clients"})
    for (const auto& e : fs::recursive_directory_iterator(root / dir)) {
      const auto ext = e.path().extension();
      if (ext != ".cpp" && ext != ".hpp" && ext != ".py") continue;
      const std::string text = slurp(e.path());
      sources += text;
      for (std::sregex_iterator m(text.begin(), text.end(), literal), end; m != end; ++m) literals.insert((*m)[1]);
    }
  // C++ members the docs describe by name (RenderResult, RenderRequest, the encode API).
  const std::set<std::string> cpp_members = {"cut_times_s", "previous_time_s", "exposure_compensation_ev",
                                             "display_nits", "reference_display_nits", "scene_cut_threshold_stops"};
  for (const auto& m : cpp_members)
    EXPECT_NE(sources.find(m), std::string::npos) << m << " is no longer in the sources";
  const std::regex ticked("`([a-z][a-z0-9_]*(?:\\.[a-z0-9_]+)*)`");
  const char* units[] = {"_nits", "_ev", "_s", "_lux", "_deg", "_percent", "_fraction", "_stops", "_px"};
  int checked = 0;
  for (const auto& e : fs::directory_iterator(root / "docs")) {
    if (e.path().extension() != ".md" || e.path().filename() == "settings.md") continue;
    const std::string doc = slurp(e.path());
    for (std::sregex_iterator m(doc.begin(), doc.end(), ticked), end; m != end; ++m) {
      const std::string name = (*m)[1];
      const bool dotted = name.find('.') != std::string::npos;
      const bool under_group = dotted && heads.count(name.substr(0, name.find('.')));
      const bool has_unit = std::any_of(std::begin(units), std::end(units), [&](const char* u) { return name.ends_with(u); });
      if (!has_unit && !under_group) continue;
      ++checked;
      if (names.count(name)) continue;
      if (std::any_of(maps.begin(), maps.end(), [&](const auto& p) { return name.rfind(p, 0) == 0; })) continue;
      if (under_group) {
        // error codes share the groups' names (`video.size`, `gainmap.mode`): no unit, no setting
        if (!has_unit) continue;
        ADD_FAILURE() << e.path().filename().string() << " names `" << name << "`, which is not a setting";
        continue;
      }
      if (components.count(name) || literals.count(name) || cpp_members.count(name)) continue;
      // A key path of what the program writes (`frame_light.frame_average_nits`): every part
      // of it is a name in its sources.
      if (dotted) {
        bool all = true;
        for (std::size_t b = 0, d; b <= name.size(); b = d + 1) {
          d = std::min(name.find('.', b), name.size());
          all = all && literals.count(name.substr(b, d - b));
        }
        if (all) continue;
      }
      ADD_FAILURE() << e.path().filename().string() << " names `" << name
                    << "`, which is not a setting (nor anything else the program reads or writes)";
    }
  }
  EXPECT_GT(checked, 50);
}

}  // namespace
}  // namespace hdrd::job

// The settings table itself: one name, one flag, one query parameter, one default per
// setting; every default valid under its own rules; docs/settings.md generated from it.
#include <gtest/gtest.h>

#include <fstream>
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

}  // namespace
}  // namespace hdrd::job

// The settings table as CLI options (tools/common/settings_cli): every flag's help and
// --help heading come from its setting, and say what the flag does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "job/settings.hpp"
#include "tools/common/settings_cli.hpp"

namespace hdrd::cli {
namespace {

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

// Issue 29 item 14: "--no-labels  Draw the cd/m2 (or %) labels" said the opposite of what
// the flag does. Every --no-x flag's help says it turns its setting off, and the flag does.
TEST(SettingsCli, EveryNoFlagSaysWhatItTurnsOff) {
  int seen = 0;
  for (const auto& s : job::settings()) {
    if (!starts_with(s.flag, "--no-")) continue;
    ++seen;
    SCOPED_TRACE(std::string(s.flag));
    const std::string h = help_of(s);
    const auto at = h.find("urn off ");
    ASSERT_NE(at, std::string::npos) << h;
    EXPECT_TRUE(at == 1 || h.substr(at - 3, 3) == ": t") << h;  // first, or after a short lead
    EXPECT_NE(h.find(std::string(s.path) + " (on by default)"), std::string::npos) << h;
    EXPECT_FALSE(starts_with(h, s.doc)) << "reads as what the flag turns on: " << h;
    // And it does turn it off.
    SettingArgs args;
    args.given.emplace_back(std::string(s.flag), "");
    auto j = request_json(args);
    ASSERT_TRUE(j.ok()) << j.error().message;
    std::string pointer = "/" + std::string(s.path);
    for (auto& c : pointer) c = c == '.' ? '/' : c;
    EXPECT_EQ(j->at(nlohmann::json::json_pointer(pointer)), false) << j->dump();
  }
  EXPECT_GE(seen, 6);  // labels, detect-cuts, dynamic-metadata, sky-sun, energy-compensation, dynamic-peak
}

// --help's headings are the settings' groups: before, --environment and --sky-* were listed
// under "Output:" (any path the CLI's own list missed fell there).
TEST(SettingsCli, EveryFlagIsListedUnderItsSettingsGroup) {
  for (const auto& s : job::settings()) EXPECT_FALSE(setting_group(s.path).empty()) << s.path << " has no group";
  for (auto source : {job::Source::render, job::Source::encode, job::Source::pattern}) {
    CLI::App app("t");
    SettingArgs args;
    add_setting_options(app, source, job::Reach::cli, args);
    for (const auto& s : job::settings()) {
      if (s.flag.empty() || !s.takes(source) || s.reach == job::Reach::daemon) continue;
      const CLI::Option* o = app.get_option_no_throw(std::string(s.flag));
      ASSERT_NE(o, nullptr) << s.flag;
      EXPECT_EQ(o->get_group(), setting_group(s.path)) << s.flag;
    }
    for (const auto& c : job::composites()) {
      if (!job::applies(c.sources, source)) continue;
      const CLI::Option* o = app.get_option_no_throw(std::string(c.flag));
      ASSERT_NE(o, nullptr) << c.flag;
      EXPECT_EQ(o->get_group(), setting_group(c.paths[0])) << c.flag;
    }
  }
  EXPECT_EQ(setting_group("environment.file"), "Environment");
  EXPECT_EQ(setting_group("environment.sky.sun"), "Environment");
}

// Choices named in a setting's doc are all of them or none: "per-channel, max-rgb or
// luminance" named three of --tonemap-apply's four (rgb is accepted too). A run of two or
// more choices joined by ", " / " or " / ", or " is taken as the doc listing the choices.
TEST(SettingsCli, ADocThatListsChoicesListsThemAll) {
  auto is_word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_'; };
  for (const auto& s : job::settings()) {
    if (s.choices.empty()) continue;
    SCOPED_TRACE(std::string(s.path));
    const std::string doc(s.doc);
    // The doc's words, in order, with the separator that follows each.
    std::vector<std::pair<std::string, std::string>> words;
    for (std::size_t i = 0; i < doc.size();) {
      if (!is_word(doc[i])) {
        ++i;
        continue;
      }
      std::size_t j = i;
      while (j < doc.size() && is_word(doc[j])) ++j;
      std::size_t k = j;
      while (k < doc.size() && !is_word(doc[k])) ++k;
      words.emplace_back(doc.substr(i, j - i), doc.substr(j, k - j));
      i = k;
    }
    auto is_choice = [&](const std::string& w) {
      return std::find(s.choices.begin(), s.choices.end(), w) != s.choices.end();
    };
    bool lists = false;
    for (std::size_t i = 0; i + 1 < words.size(); ++i) {
      const auto& sep = words[i].second;
      const bool joined = sep == ", " || sep == " or " || sep == ", or ";
      if (is_choice(words[i].first) && joined && is_choice(words[i + 1].first)) lists = true;
    }
    if (!lists) continue;
    for (auto c : s.choices) {
      const bool named = std::any_of(words.begin(), words.end(), [&](const auto& w) { return w.first == c; });
      EXPECT_TRUE(named) << "the doc lists choices but not '" << c << "': " << doc;
    }
  }
}

}  // namespace
}  // namespace hdrd::cli

// POST /v1/pattern and /v1/selftest requests: fields, defaults, ranges and errors; the
// daemon's pattern catalogue against the pattern library it stands for (same names, and
// every parameter's range and default accepted by the library).
#include <gtest/gtest.h>

#include <set>

#include "daemon/pattern_catalogue.hpp"
#include "daemon/request.hpp"
#include "patterns/patterns.hpp"

namespace hdrd::daemon {
namespace {

Result<Request> parse_pattern(const std::string& body) {
  ParseContext ctx;
  ctx.endpoint = Endpoint::pattern;
  return parse_request(body, ctx);
}

TEST(PatternRequest, DefaultsAreTheLibraryLayout) {
  auto r = parse_pattern(R"({"pattern":"window"})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->pattern.name, "window");
  EXPECT_EQ(r->width, 1920);
  EXPECT_EQ(r->height, 1080);
  const patterns::PatternOptions lib;
  EXPECT_EQ(r->pattern.level_nits, lib.level_nits) << "0: the display peak";
  EXPECT_EQ(r->pattern.area_percent, lib.area_percent);
  EXPECT_EQ(r->pattern.steps, lib.steps);
  EXPECT_EQ(r->pattern.labels, lib.labels);
  EXPECT_EQ(r->display.target.mode, Mode::hdr10);
}

TEST(PatternRequest, ParametersAndDisplay) {
  auto r = parse_pattern(
      R"({"pattern":"window","params":{"level_nits":600,"area_percent":2},"width":96,"height":54,
          "display":{"mode":"hdr10","peak_nits":600}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->pattern.level_nits, 600);
  EXPECT_EQ(r->pattern.area_percent, 2);
  EXPECT_EQ(r->width, 96);
  EXPECT_EQ(r->display.target.peak_nits, 600);
  r = parse_pattern(R"({"pattern":"pq-ramp","params":{"steps":21,"labels":false}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->pattern.steps, 21);
  EXPECT_FALSE(r->pattern.labels);
}

TEST(PatternRequest, LimitsApplyToTheDefaultSize) {
  ParseContext ctx;
  ctx.endpoint = Endpoint::pattern;
  ctx.limits.max_width = 640;
  ctx.limits.max_height = 480;
  auto r = parse_request(R"({"pattern":"pq-ramp"})", ctx);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->width, 640);
  EXPECT_EQ(r->height, 480);
}

struct Bad {
  const char* body;
  const char* code;
  const char* field;
};
class PatternRequestRejects : public ::testing::TestWithParam<Bad> {};

TEST_P(PatternRequestRejects, WithCodeAndField) {
  const auto& b = GetParam();
  auto r = parse_pattern(b.body);
  ASSERT_FALSE(r.ok()) << b.body;
  EXPECT_EQ(r.error().code, b.code) << b.body << ": " << r.error().message;
  EXPECT_EQ(r.error().field, b.field) << b.body << ": " << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << "one line";
}

INSTANTIATE_TEST_SUITE_P(
    Table, PatternRequestRejects,
    ::testing::Values(Bad{"{}", "request.value", "pattern"},
                      Bad{R"({"pattern":"smpte-bars"})", "request.value", "pattern"},
                      Bad{R"({"pattern":7})", "request.type", "pattern"},
                      Bad{R"({"pattern":"window","params":{"level":100}})", "request.unknown_field", "params.level"},
                      Bad{R"({"pattern":"window","params":{"steps":5}})", "request.unknown_field", "params.steps"},
                      Bad{R"({"pattern":"window","params":{"level_nits":"max"}})", "request.type", "params.level_nits"},
                      Bad{R"({"pattern":"window","params":{"level_nits":20000}})", "request.value", "params.level_nits"},
                      Bad{R"({"pattern":"window","params":{"area_percent":0}})", "request.value", "params.area_percent"},
                      Bad{R"({"pattern":"window","params":[1]})", "request.type", "params"},
                      Bad{R"({"pattern":"near-black","params":{"steps":11}})", "request.value", "params.steps"},
                      Bad{R"({"pattern":"pq-ramp","params":{"steps":2.5}})", "request.type", "params.steps"},
                      Bad{R"({"pattern":"pq-ramp","params":{"labels":"no"}})", "request.type", "params.labels"},
                      Bad{R"({"pattern":"bt2111","display":{"mode":"sdr"}})", "request.value", "display.mode"},
                      Bad{R"({"pattern":"window","width":100000})", "request.limit", "width"},
                      Bad{R"({"pattern":"window","tone":{"curve":"clip"}})", "request.unknown_field", "tone"},
                      Bad{R"({"pattern":"window","exposure_comp_ev":1})", "request.unknown_field", "exposure_comp_ev"},
                      Bad{R"({"pattern":"window","dither":true})", "request.unknown_field", "dither"},
                      Bad{R"({"pattern":"window","scene":"hdr"})", "request.unknown_field", "scene"},
                      Bad{R"({"pattern":"window","samples":4})", "request.unknown_field", "samples"},
                      Bad{R"({"pattern":"window","name":"../x","dump":true})", "request.value", "name"}));

TEST(PatternRequest, CanonicalJsonSeparatesPatternsAndParameters) {
  auto a = parse_pattern(R"({"pattern":"window","params":{"level_nits":600}})");
  auto b = parse_pattern(R"({"params":{"level_nits":600.0},"pattern":"window"})");
  auto c = parse_pattern(R"({"pattern":"window","params":{"level_nits":601}})");
  auto d = parse_pattern(R"({"pattern":"clipping","params":{"level_nits":600}})");
  ASSERT_TRUE(a.ok() && b.ok() && c.ok() && d.ok());
  EXPECT_EQ(a->canonical().dump(), b->canonical().dump());
  EXPECT_NE(a->canonical().dump(), c->canonical().dump());
  EXPECT_NE(a->canonical().dump(), d->canonical().dump());
}

// ---- the catalogue against the library ------------------------------------------------

TEST(PatternCatalogue, NamesAreExactlyTheLibrarys) {
  std::set<std::string> lib, ours;
  for (const auto& p : patterns::patterns()) lib.emplace(p.name);
  for (const auto& e : pattern_catalogue()) ours.emplace(e.name);
  EXPECT_EQ(ours, lib);
}

patterns::PatternOptions with_param(const PatternParam& p, double v) {
  patterns::PatternOptions o;
  o.width = 512, o.height = 256;
  if (p.name == "level_nits") o.level_nits = v;
  if (p.name == "area_percent") o.area_percent = v;
  if (p.name == "steps") o.steps = int(v);
  if (p.name == "labels") o.labels = v != 0;
  return o;
}

// Every value the validator lets through must be one the library can draw.
TEST(PatternCatalogue, TheLibraryAcceptsEveryRangeEndAndDefault) {
  for (const auto& e : pattern_catalogue()) {
    const Mode mode = e.modes.empty() ? Mode::hdr10 : e.modes.front();
    const DisplayTarget t = default_target(mode);
    patterns::PatternOptions small;
    small.width = 512, small.height = 256;
    EXPECT_TRUE(patterns::make_pattern(e.name, t, small, false).ok()) << e.name;
    for (const auto& p : e.params) {
      std::vector<double> values = {p.min, p.max};
      if (p.default_value) values.push_back(*p.default_value);
      for (double v : values) {
        auto f = patterns::make_pattern(e.name, t, with_param(p, v), false);
        EXPECT_TRUE(f.ok()) << e.name << " " << p.name << "=" << v << ": " << (f ? "" : f.error().message);
      }
    }
  }
}

TEST(PatternCatalogue, ModeRestrictionsMatchTheLibrary) {
  patterns::PatternOptions o;
  o.width = 96, o.height = 54;
  for (const auto& e : pattern_catalogue())
    for (Mode m : {Mode::hdr10, Mode::hlg, Mode::scrgb, Mode::sdr, Mode::sdr_bt1886}) {
      const bool listed = e.modes.empty() || std::find(e.modes.begin(), e.modes.end(), m) != e.modes.end();
      EXPECT_EQ(patterns::make_pattern(e.name, default_target(m), o, false).ok(), listed)
          << e.name << " in " << to_string(m);
    }
}

// ---- POST /v1/selftest --------------------------------------------------------------------

TEST(SelftestRequest, EmptyBodyIsHdr10AtItsDefaultPeak) {
  for (const char* body : {"", "  \n", "{}"}) {
    auto r = parse_selftest_request(body, ParseContext{});
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->mode, "hdr10");
    EXPECT_FALSE(r->peak_nits.has_value());
    EXPECT_TRUE(r->render);
  }
  auto r = parse_selftest_request(R"({"mode":"sdr-bt1886","peak_nits":250,"render":false})", ParseContext{});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->mode, "sdr-bt1886");
  EXPECT_EQ(*r->peak_nits, 250);
  EXPECT_FALSE(r->render);
}

TEST(SelftestRequest, Rejects) {
  const Bad table[] = {{R"({"mode":"hdr12"})", "request.value", "mode"},
                       {R"({"mode":10})", "request.type", "mode"},
                       {R"({"peak_nits":0})", "request.value", "peak_nits"},
                       {R"({"peak":1000})", "request.unknown_field", "peak"},
                       {R"({"render":"yes"})", "request.type", "render"},
                       {R"({"mode":"hdr10")", "request.syntax", ""},
                       {"[]", "request.type", ""}};
  for (const auto& b : table) {
    auto r = parse_selftest_request(b.body, ParseContext{});
    ASSERT_FALSE(r.ok()) << b.body;
    EXPECT_EQ(r.error().code, b.code) << b.body << ": " << r.error().message;
    EXPECT_EQ(r.error().field, b.field) << b.body;
  }
}

}  // namespace
}  // namespace hdrd::daemon

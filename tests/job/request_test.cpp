// The request model: every setting's type, range and default; unknown fields; limits;
// REFERENCE.md §1.8 per-mode defaults through the one levels resolver; base64 against RFC
// 4648 §10's test vectors; the three spellings (JSON, CLI flags, query) of one request.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <algorithm>

#include "job/outputs.hpp"
#include "job/pattern_params.hpp"
#include "job/request.hpp"
#include "patterns/patterns.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::job {
namespace {

namespace fs = std::filesystem;

ParseContext context(Source source = Source::render, Reach reach = Reach::daemon, fs::path root = {}) {
  ParseContext ctx;
  ctx.source = source;
  ctx.reach = reach;
  if (!root.empty())
    ctx.resolve_path = [root](std::string_view p, const std::string&) -> Result<fs::path> { return root / p; };
  return ctx;
}

Result<FrameRequest> parse(const std::string& body, Source source = Source::render, fs::path root = {}) {
  return parse_request(body, context(source, Reach::daemon, std::move(root)));
}

TEST(Request, EmptyObjectGetsTheTableDefaults) {
  auto r = parse("{}");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->integer("width"), 1920);
  EXPECT_EQ(r->integer("height"), 1080);
  EXPECT_EQ(r->integer("samples"), 4);
  EXPECT_EQ(r->scene.kind, SceneRef::Kind::builtin);
  EXPECT_EQ(r->scene.name, "material-grid");
  EXPECT_TRUE(r->is_null("display.mode")) << "the mode is decided with the display";
  EXPECT_EQ(r->text("exposure.mode"), "auto");
  EXPECT_EQ(r->text("tone.curve"), "pq-shoulder");
  EXPECT_FALSE(r->boolean("dump"));
  EXPECT_TRUE(r->given.empty());
}

TEST(Request, TheIssueExampleParses) {
  auto r = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1000}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->integer("width"), 256);
  EXPECT_EQ(r->integer("height"), 144);
  EXPECT_EQ(r->number("display.peak_nits"), 1000);
  EXPECT_TRUE(r->has("display.peak_nits"));
  EXPECT_FALSE(r->has("display.paper_white_nits"));
}

// REFERENCE.md §1.8, typed in from the table (not from default_target()), through the
// resolver every front end uses.
struct ModeDefaults {
  const char* mode;
  double peak, black, paper;
};
void PrintTo(const ModeDefaults& m, std::ostream* os) {
  *os << m.mode << " peak " << m.peak << " black " << m.black << " paper white " << m.paper;
}
class ResolverModeDefaults : public ::testing::TestWithParam<ModeDefaults> {};

TEST_P(ResolverModeDefaults, FollowReferenceTable) {
  const auto& d = GetParam();
  auto r = parse(std::string(R"({"display":{"mode":")") + d.mode + R"("}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto t = resolve_target(*parse_mode(d.mode), {}, request_levels(*r));
  ASSERT_TRUE(t.ok());
  EXPECT_DOUBLE_EQ(t->peak_nits, d.peak);
  EXPECT_DOUBLE_EQ(t->black_nits, d.black);
  EXPECT_DOUBLE_EQ(t->paper_white_nits, d.paper);
  EXPECT_DOUBLE_EQ(t->ui_white_nits, t->paper_white_nits) << "ui white defaults to paper white (§1.4)";
  EXPECT_DOUBLE_EQ(t->sdr_white_nits, t->paper_white_nits) << "sdr white defaults to paper white (§1.4)";
  EXPECT_EQ(t->range, Range::full);
  EXPECT_EQ(t->source, "defaults") << "a mode alone sets no level";
}
INSTANTIATE_TEST_SUITE_P(Reference18, ResolverModeDefaults,
                         ::testing::Values(ModeDefaults{"hdr10", 1000, 0.005, 203}, ModeDefaults{"hlg", 1000, 0, 203},
                                           ModeDefaults{"scrgb", 1000, 0, 203}, ModeDefaults{"sdr", 100, 0.1, 100},
                                           ModeDefaults{"sdr-bt1886", 100, 0.1, 100}),
                         [](const auto& info) {
                           std::string n = info.param.mode;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

TEST(Request, SdrPaperWhiteFollowsAGivenPeak) {
  // §1.8: SDR paper white "= peak"; UI and SDR white follow paper white (§1.4).
  auto r = parse(R"({"display":{"mode":"sdr","peak_nits":250}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto t = resolve_target(Mode::sdr, {}, request_levels(*r));
  EXPECT_DOUBLE_EQ(t->paper_white_nits, 250);
  EXPECT_DOUBLE_EQ(t->ui_white_nits, 250);
  EXPECT_EQ(t->source, "defaults+request");
  // An HDR mode keeps 203 whatever the peak.
  r = parse(R"({"display":{"mode":"hdr10","peak_nits":600,"ui_white_nits":300}})");
  ASSERT_TRUE(r.ok());
  t = resolve_target(Mode::hdr10, {}, request_levels(*r));
  EXPECT_DOUBLE_EQ(t->paper_white_nits, 203);
  EXPECT_DOUBLE_EQ(t->ui_white_nits, 300);
  EXPECT_DOUBLE_EQ(t->sdr_white_nits, 203);
}

TEST(Request, ExposureCompensationUnderEitherName) {
  auto r = parse(R"({"exposure_comp_ev":1.5})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->number("exposure.compensation_ev"), 1.5);
  r = parse(R"({"exposure":{"compensation_ev":-2,"mode":"histogram","percentile":95}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->number("exposure.compensation_ev"), -2);
  EXPECT_EQ(r->text("exposure.mode"), "histogram");
  EXPECT_DOUBLE_EQ(r->number("exposure.percentile"), 95);
  r = parse(R"({"exposure_comp_ev":1,"exposure":{"compensation_ev":2}})");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.conflict");
  EXPECT_TRUE(parse(R"({"exposure_comp_ev":1,"exposure":{"compensation_ev":1}})").ok()) << "agreeing is fine";
}

struct Bad {
  const char* name;
  const char* body;
  const char* code;
  const char* field;
};
void PrintTo(const Bad& b, std::ostream* os) { *os << b.name << " -> " << b.code; }
class RequestRejects : public ::testing::TestWithParam<Bad> {};

TEST_P(RequestRejects, WithCodeAndField) {
  const auto& b = GetParam();
  auto r = parse(b.body);
  ASSERT_FALSE(r.ok()) << b.body;
  EXPECT_EQ(r.error().code, b.code) << b.body << ": " << r.error().message;
  EXPECT_EQ(r.error().field, b.field) << b.body << ": " << r.error().message;
  EXPECT_FALSE(r.error().message.empty());
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << "one line";
}

INSTANTIATE_TEST_SUITE_P(
    Table, RequestRejects,
    ::testing::Values(
        Bad{"unterminated", R"({"width":256)", "request.syntax", ""}, Bad{"empty", "", "request.syntax", ""},
        Bad{"array", "[1,2]", "request.type", ""}, Bad{"null", "null", "request.type", ""},
        Bad{"width_string", R"({"width":"256"})", "request.type", "width"},
        Bad{"width_fraction", R"({"width":25.5})", "request.type", "width"},
        Bad{"width_zero", R"({"width":0})", "request.value", "width"},
        Bad{"width_over_limit", R"({"width":10000})", "request.limit", "width"},
        Bad{"width_huge", R"({"width":1e300})", "request.limit", "width"},
        Bad{"width_unsigned_max", R"({"width":18446744073709551615})", "request.limit", "width"},
        Bad{"number_overflow", R"({"width":1e400})", "request.value", "width"},
        Bad{"number_overflow_nested", R"({"display":{"peak_nits":5e551}})", "request.value", "display.peak_nits"},
        Bad{"invalid_utf8_string", "{\"name\":\"\xff\",\"dump\":true}", "request.syntax", ""},
        Bad{"samples_over_table", R"({"samples":100})", "request.limit", "samples"},
        Bad{"pixels_over_limit", R"({"width":7680,"height":4321})", "request.limit", "height"},
        Bad{"bits_3", R"({"display":{"bits":3}})", "request.value", "display.bits"},
        Bad{"sdr_12_bits", R"({"display":{"mode":"sdr","bits":12}})", "request.value", "display.bits"},
        Bad{"typo", R"({"widht":256})", "request.unknown_field", "widht"},
        Bad{"unknown_display_field", R"({"display":{"mode":"hdr10","peak":1000}})", "request.unknown_field",
            "display.peak"},
        Bad{"unknown_mode", R"({"display":{"mode":"hdr11"}})", "request.value", "display.mode"},
        Bad{"negative_peak", R"({"display":{"peak_nits":-5}})", "request.value", "display.peak_nits"},
        Bad{"peak_above_pq", R"({"display":{"peak_nits":20000}})", "request.value", "display.peak_nits"},
        Bad{"peak_string", R"({"display":{"peak_nits":"1000"}})", "request.type", "display.peak_nits"},
        Bad{"black_above_peak", R"({"display":{"peak_nits":100,"black_nits":200}})", "request.value",
            "display.black_nits"},
        Bad{"display_number", R"({"display":5})", "request.type", "display"},
        Bad{"studio_range", R"({"display":{"range":"studio"}})", "request.value", "display.range"},
        Bad{"scrgb_narrow", R"({"display":{"mode":"scrgb","range":"narrow"}})", "request.value", "display.range"},
        Bad{"curve_number", R"({"tone":{"curve":5}})", "request.type", "tone.curve"},
        Bad{"unknown_curve", R"({"tone":{"curve":"magic"}})", "request.value", "tone.curve"},
        Bad{"param_string", R"({"tone":{"params":{"w":"x"}}})", "request.type", "tone.params.w"},
        Bad{"param_unknown", R"({"tone":{"curve":"reinhard","params":{"nope":1}}})", "request.value", "tone.params"},
        Bad{"apply_sideways", R"({"tone":{"apply":"sideways"}})", "request.value", "tone.apply"},
        Bad{"exposure_automatic", R"({"exposure":{"mode":"automatic"}})", "request.value", "exposure.mode"},
        Bad{"iso_zero", R"({"exposure":{"iso":0}})", "request.value", "exposure.iso"},
        Bad{"ignore_all", R"({"exposure":{"ignore_dark_fraction":0.6,"ignore_bright_fraction":0.5}})",
            "request.value", "exposure.ignore_bright_fraction"},
        Bad{"camera_pair", R"({"camera":{"position":[1,2]}})", "request.type", "camera.position"},
        Bad{"fov_180", R"({"camera":{"fov_y_deg":180}})", "request.value", "camera.fov_y_deg"},
        Bad{"scene_number", R"({"scene":42})", "request.type", "scene"},
        Bad{"formats_without_dump", R"({"formats":["png"]})", "request.conflict", "formats"},
        Bad{"format_tiff", R"({"dump":true,"formats":["tiff"]})", "request.value", "formats"},
        Bad{"dump_name_traversal", R"({"dump":true,"name":"../evil"})", "request.value", "name"},
        Bad{"dump_name_hidden", R"({"dump":true,"name":".hidden"})", "request.value", "name"},
        Bad{"dump_name_frame_of_another", R"({"dump":true,"name":"clash.00001"})", "name.collision", "name"},
        Bad{"dump_name_metadata_of_another", R"({"dump":true,"name":"a.hdr10plus"})", "name.collision", "name"},
        Bad{"dump_name_scene_exr_of_another", R"({"dump":true,"name":"a.scene"})", "name.collision", "name"},
        Bad{"dump_yes", R"({"dump":"yes"})", "request.type", "dump"},
        Bad{"file_without_root", R"({"scene":"x.gltf"})", "path.forbidden", "scene"},
        Bad{"base64_garbage", R"({"ui":{"png_base64":"@@@@"}})", "request.value", "ui.png_base64"},
        Bad{"base64_empty", R"({"ui":{"png_base64":""}})", "request.value", "ui.png_base64"},
        Bad{"ui_without_png", R"({"ui":{"x":1}})", "request.value", "ui.path"},
        Bad{"grade_without_lut", R"({"grade":{"placement":"scene"}})", "request.value", "grade.placement"},
        Bad{"timeout_zero", R"({"timeout_s":0})", "request.value", "timeout_s"},
        Bad{"threads_per_request", R"({"threads":4})", "request.unknown_field", "threads"},
        Bad{"input_for_render", R"({"input":"relative"})", "request.unknown_field", "input"}),
    [](const auto& info) { return std::string(info.param.name); });

// A key or value quoted in a message may hold control characters ("\n" in a JSON key, %0A in
// a query parameter); the message stays one line, the field keeps the key as sent.
TEST(Request, MessagesStayOneLineWhateverTheyQuote) {
  auto r = parse(R"({"a\nb":1})");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "a\nb");
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  auto q = query_to_request_json({{"mo\nde", "hdr10"}});
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.error().message.find('\n'), std::string::npos) << q.error().message;
}

// nlohmann's lexer ends its input at a NUL byte: without the bounded parse, what followed
// one was ignored and the request before it taken as the whole body (issue 14).
TEST(Request, NulBytesAreRefusedNotCutAt) {
  auto r = parse(std::string("{\"width\":256}\0{\"width\":1}", 25));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.syntax");
  EXPECT_NE(r.error().message.find("NUL byte at byte 13"), std::string::npos) << r.error().message;
  r = parse(std::string("{\"name\":\"a\\u0000b\",\"dump\":true}"));
  ASSERT_FALSE(r.ok()) << "an escaped NUL inside a string";
  EXPECT_EQ(r.error().field, "name");
}

TEST(Request, ConfiguredLimitsApply) {
  auto ctx = context();
  ctx.limits.max_samples = 8;
  ctx.limits.max_width = 640;
  auto r = parse_request(R"({"samples":16,"width":640,"height":360})", ctx);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.limit");
  EXPECT_EQ(r.error().field, "samples");
  r = parse_request(R"({"width":641,"height":10})", ctx);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "width");
  r = parse_request(R"({"height":10})", ctx);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("the default 1920"), std::string::npos) << r.error().message;
}

// Depth is bounded while the text is read: 100 000 levels never become a document (issue
// 14: a multipart part that deep crashed the daemon); brackets inside strings do not count.
TEST(Request, NestingDepthIsRefusedWhileParsing) {
  for (int levels : {100, 100000}) {
    auto r = parse(std::string(levels, '[') + std::string(levels, ']'));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, "request.depth") << levels;
  }
  auto unclosed = parse(std::string(100000, '['));
  ASSERT_FALSE(unclosed.ok());
  EXPECT_EQ(unclosed.error().code, "request.depth") << "refused before the text ends";
  auto ctx = context();
  ctx.limits.max_json_depth = 4;
  auto in_string = parse_request(R"({"grade":{"ocio_look":"[[[[{{{{[[[["}})", ctx);
  EXPECT_TRUE(in_string.ok()) << in_string.error().message;
  EXPECT_EQ(parse_request(R"({"display":{"x":[[[1]]]}})", ctx).error().code, "request.depth") << "5 levels, 4 allowed";
}

TEST(Request, BodyOverTheLimitIsTooLarge) {
  auto ctx = context();
  ctx.limits.max_body_bytes = 1024;
  auto r = parse_request(R"({"name":")" + std::string(2000, 'a') + R"("})", ctx);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.too_large");
  auto bounded = parse_json_object_bounded("[1]", ctx.limits, "the 'request' part");
  ASSERT_FALSE(bounded.ok());
  EXPECT_EQ(bounded.error().code, "request.type");
  EXPECT_NE(bounded.error().message.find("the 'request' part"), std::string::npos) << bounded.error().message;
}

TEST(Request, TooManyLightsInAnInlineScene) {
  std::string lights;
  for (int i = 0; i < 300; ++i) lights += std::string(i ? "," : "") + "{}";
  auto r = parse(R"({"scene":{"lights":[)" + lights + "]}}");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.limit");
  EXPECT_EQ(r.error().field, "scene.lights");
}

TEST(Request, EachSourceTakesItsOwnSettings) {
  auto r = parse(R"({"width":10})", Source::encode);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.unknown_field");
  r = parse(R"({"input":"absolute","display":{"mode":"hlg"}})", Source::encode);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->text("input"), "absolute");
  r = parse(R"({"pattern":"window","tone":{"curve":"clip"}})", Source::pattern);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "tone.curve");
  EXPECT_NE(r.error().message.find("patterns are display light"), std::string::npos) << r.error().message;
}

TEST(Request, CanonicalJsonIsTheSameForEquivalentRequests) {
  auto a = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1000}})");
  auto b = parse(R"({"display":{"peak_nits":1000.0,"mode":"hdr10"},"height":144,"width":256})");
  auto c = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1001}})");
  auto d = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1000},"exposure_comp_ev":0})");
  ASSERT_TRUE(a.ok() && b.ok() && c.ok() && d.ok());
  EXPECT_EQ(a->canonical().dump(), b->canonical().dump());
  EXPECT_EQ(a->canonical().dump(), d->canonical().dump()) << "saying the default is saying nothing";
  EXPECT_NE(a->canonical().dump(), c->canonical().dump());
}

TEST(Request, PathsAreResolvedByTheFrontEnd) {
  testing::TempDir tmp;
  std::ofstream(tmp / "grade.cube") << "LUT_3D_SIZE 2\n";
  auto r = parse(R"({"grade":{"lut":"grade.cube","placement":"scene","shaper":"log2:-8:8"}})", Source::render,
                 tmp.path());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->text("grade.lut"), (tmp / "grade.cube").string());
  EXPECT_EQ(r->text("grade.shaper"), "log2:-8:8");
  r = parse(R"({"scene":"models/box.gltf"})", Source::render, tmp.path());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->scene.kind, SceneRef::Kind::file);
  EXPECT_EQ(r->scene.path, tmp / "models/box.gltf");
  r = parse(R"({"grade":{"lut":"grade.cube","shaper":"log2:x"}})", Source::render, tmp.path());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "grade.shaper");
}

// ---- the three spellings ------------------------------------------------------------------

TEST(Spellings, CliFlagsQueryAndJsonGiveTheSameRequest) {
  const auto json = parse(
      R"({"display":{"mode":"sdr","peak_nits":250},"tone":{"curve":"reinhard-extended","params":{"white":4}},
          "exposure":{"compensation_ev":-1},"ui":{"path":"hud.png","x":16,"y":8},"camera":{"position":[0,1,2],
          "target":[0,0,0],"fov_y_deg":40},"formats":["png","raw"],"dump":true})",
      Source::render, "/r");
  ASSERT_TRUE(json.ok()) << json.error().message;
  auto cli = cli_to_request_json({{"--mode", "sdr"},
                                  {"--peak", "250"},
                                  {"--tonemap", "reinhard-extended"},
                                  {"--tonemap-param", "white=4"},
                                  {"--exposure", "-1"},
                                  {"--ui", "hud.png"},
                                  {"--ui-pos", "16,8"},
                                  {"--camera", "0,1,2:0,0,0:40"},
                                  {"--format", "png,raw"}});
  ASSERT_TRUE(cli.ok()) << cli.error().message;
  (*cli)["dump"] = true;  // the daemon's transport; the CLI always dumps
  auto from_cli = parse_request_json(*cli, context(Source::render, Reach::daemon, "/r"));
  ASSERT_TRUE(from_cli.ok()) << from_cli.error().message;
  EXPECT_EQ(json->canonical(), from_cli->canonical());

  auto q = query_to_request_json({{"mode", "sdr"}, {"peak_nits", "250"}, {"curve", "reinhard"}, {"dump", ""}});
  ASSERT_TRUE(q.ok()) << q.error().message;
  EXPECT_EQ((*q)["display"]["mode"], "sdr");
  EXPECT_EQ((*q)["display"]["peak_nits"], 250);
  EXPECT_EQ((*q)["tone"]["curve"], "reinhard");
  EXPECT_EQ((*q)["dump"], true);
}

TEST(Spellings, ErrorsNameWhatTheUserTyped) {
  auto cli = cli_to_request_json({{"--peak", "20000"}});
  ASSERT_TRUE(cli.ok());
  auto ctx = context(Source::render, Reach::cli);
  ctx.spelling = Spelling::cli;
  auto r = parse_request_json(*cli, ctx);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "display.peak_nits");
  EXPECT_EQ(r.error().message.rfind("--peak:", 0), 0u) << r.error().message;
  EXPECT_EQ(cli_to_request_json({{"--peak", "bright"}}).error().message.rfind("--peak:", 0), 0u);
  EXPECT_EQ(cli_to_request_json({{"--camera", "1,2"}}).error().code, "request.type");
  EXPECT_EQ(cli_to_request_json({{"--ui-pos", "1"}}).error().code, "request.type");
  EXPECT_EQ(cli_to_request_json({{"--tonemap-param", "white"}}).error().code, "request.type");
  EXPECT_EQ(query_to_request_json({{"peak", "1"}}).error().code, "request.unknown_field");
  EXPECT_EQ(query_to_request_json({{"peak_nits", "lots"}}).error().code, "request.type");
  EXPECT_EQ(query_to_request_json({{"peak_nits", "1"}, {"peak_nits", "2"}}).error().code, "request.conflict");
}

// Invalid UTF-8 in a query string is the client's fault, for every parameter (RFC 3629:
// stray continuation bytes, overlong forms, surrogates, code points above U+10FFFF).
TEST(Spellings, QueryParametersMustBeUtf8) {
  const std::string bad[] = {"\xff", "\x80", "a\xc3", "\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80"};
  for (const auto& s : settings()) {
    if (s.query.empty()) continue;
    for (const auto& b : bad) {
      auto q = query_to_request_json({{std::string(s.query), b}});
      ASSERT_FALSE(q.ok()) << s.query;
      EXPECT_EQ(q.error().code, "request.value") << s.query;
    }
  }
  EXPECT_TRUE(query_to_request_json({{"name", "caf\xc3\xa9"}}).ok()) << "valid UTF-8 passes";
}

// ---- patterns ----------------------------------------------------------------------------

TEST(PatternRequests, CatalogueNamesArePatternLibraryNames) {
  std::set<std::string> ours, theirs;
  for (const auto& e : pattern_catalogue()) ours.emplace(e.name);
  for (const auto& p : patterns::patterns()) theirs.emplace(p.name);
  EXPECT_EQ(ours, theirs);
  for (const auto& e : pattern_catalogue())
    for (auto path : e.params) EXPECT_NE(find_setting(path), nullptr) << path;
}

TEST(PatternRequests, ParametersBelongToTheirPattern) {
  auto r = parse(R"({"pattern":"window","params":{"level_nits":600,"area_percent":10}})", Source::pattern);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->number("params.level_nits"), 600);
  r = parse(R"({"pattern":"window","params":{"steps":5}})", Source::pattern);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.unknown_field");
  EXPECT_EQ(r.error().field, "params.steps");
  r = parse(R"({"pattern":"near-black","params":{"steps":11}})", Source::pattern);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "params.steps");
  r = parse(R"({"pattern":"bt2111","display":{"mode":"sdr"}})", Source::pattern);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "display.mode");
  EXPECT_EQ(parse("{}", Source::pattern).error().field, "pattern");
  EXPECT_EQ(parse(R"({"pattern":"zebra"})", Source::pattern).error().field, "pattern");
}

// ---- base64: RFC 4648 §10 test vectors ------------------------------------------------

TEST(Base64, Rfc4648Vectors) {
  const std::pair<const char*, const char*> v[] = {{"", ""},         {"Zg==", "f"},       {"Zm8=", "fo"},
                                                   {"Zm9v", "foo"},  {"Zm9vYg==", "foob"}, {"Zm9vYmE=", "fooba"},
                                                   {"Zm9vYmFy", "foobar"}};
  for (const auto& [enc, dec] : v) {
    auto r = decode_base64(enc, 100);
    ASSERT_TRUE(r.ok()) << enc;
    EXPECT_EQ(std::string(r->begin(), r->end()), dec);
  }
  EXPECT_FALSE(decode_base64("Zm9v!", 100).ok());
  EXPECT_FALSE(decode_base64("Z", 100).ok());
  EXPECT_EQ(decode_base64("Zm9vYmFy", 5).error().code, "request.limit");
}

// Name ownership is per file. The oracle: the file names each name would own, spelled out
// (every output's and metadata file's name, per-frame files for frames 0..2 and 1..99999's
// "00001"), compared as sets. Two names the parser accepts never share a file; every name
// it refuses shares one with another name of the set.
TEST(Request, AcceptedNamesNeverShareAFile) {
  const std::vector<std::string> names = {"a", "a.00001", "a.00002.png", "a.scene", "a.heatmap", "a.hdr10plus", "a.dovi",
                                          "a.v2", "a.json", "a.b", "a.b.00001", "a.0001", "a.000001", "clash"};
  const auto files_of = [](const std::string& n) {
    std::set<std::string> out;
    for (const char* s : {".json", ".hdr10plus.json", ".dovi.json", ".mp4", ".mkv"}) out.insert(n + s);
    for (const auto& o : outputs()) {
      out.insert(n + std::string(o.suffix));
      for (const char* frame : {".00000", ".00001", ".00002"}) {
        out.insert(n + frame + std::string(o.suffix));
        out.insert(n + frame + ".json");
      }
    }
    return out;
  };
  const auto share = [&](const std::string& x, const std::string& y) {
    const auto fx = files_of(x), fy = files_of(y);
    return std::any_of(fx.begin(), fx.end(), [&](const std::string& f) { return fy.count(f) != 0; });
  };
  std::vector<std::string> accepted;
  for (const auto& n : names) {
    auto r = parse(nlohmann::json{{"dump", true}, {"name", n}}.dump());
    if (r.ok()) {
      accepted.push_back(n);
      continue;
    }
    EXPECT_EQ(r.error().code, "name.collision") << n << ": " << r.error().message;
    const bool collides = std::any_of(names.begin(), names.end(), [&](const std::string& m) { return m != n && share(n, m); });
    EXPECT_TRUE(collides) << n << " refused, but its files are no other name's";
  }
  for (std::size_t i = 0; i < accepted.size(); ++i)
    for (std::size_t j = i + 1; j < accepted.size(); ++j)
      EXPECT_FALSE(share(accepted[i], accepted[j])) << accepted[i] << " and " << accepted[j] << " share a file";
  EXPECT_NE(std::find(accepted.begin(), accepted.end(), "a.v2"), accepted.end());
  EXPECT_NE(std::find(accepted.begin(), accepted.end(), "a.0001"), accepted.end()) << "4 digits are no frame number";
}

// Patterns are exact display levels: the frame-average limit (a scene-referred exposure
// setting) is refused there, by name, and never reaches the encoder.
TEST(Request, FrameAverageLimitIsRefusedForPatterns) {
  auto p = parse(R"({"pattern":"window","tone":{"max_frame_average_nits":400}})", Source::pattern);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, "request.unknown_field");
  EXPECT_EQ(p.error().field, "tone.max_frame_average_nits");
  auto r = parse(R"({"tone":{"max_frame_average_nits":400}})", Source::render);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->optional_number("tone.max_frame_average_nits"), 400);
  EXPECT_FALSE(parse(R"({"tone":{"max_frame_average_nits":0}})", Source::render).ok()) << "at least 1 cd/m2";
}

}  // namespace
}  // namespace hdrd::job

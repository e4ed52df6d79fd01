// The request model: every field's type, range and default; unknown fields; limits;
// paths confined to the asset root; REFERENCE.md §1.8 per-mode defaults; base64 against
// RFC 4648 §10's test vectors; Accept negotiation (RFC 9110 §12.5.1); error -> status.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "daemon/input_bounds.hpp"
#include "daemon/output.hpp"
#include "daemon/paths.hpp"
#include "daemon/request.hpp"
#include "daemon/wire_error.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::daemon {
namespace {

namespace fs = std::filesystem;

Result<Request> parse(const std::string& body, Endpoint ep = Endpoint::render, fs::path root = {}) {
  ParseContext ctx;
  ctx.endpoint = ep;
  ctx.asset_root = std::move(root);
  ctx.defaults.width = 320;
  ctx.defaults.height = 180;
  return parse_request(body, ctx);
}

TEST(Request, EmptyObjectGetsConfiguredDefaults) {
  auto r = parse("{}");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->width, 320);
  EXPECT_EQ(r->height, 180);
  EXPECT_EQ(r->samples, 1);
  EXPECT_EQ(r->scene.kind, SceneSpec::Kind::builtin);
  EXPECT_EQ(r->scene.name, "material-grid");
  EXPECT_EQ(r->display.target.mode, Mode::hdr10);
  EXPECT_FALSE(r->dump);
}

TEST(Request, TheIssueExampleParses) {
  auto r = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1000}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->width, 256);
  EXPECT_EQ(r->height, 144);
  EXPECT_EQ(r->display.target.peak_nits, 1000);
  EXPECT_EQ(r->display.target.paper_white_nits, 203);  // BT.2408 reference white
}

// REFERENCE.md §1.8, typed in from the table (not from default_target()).
struct ModeDefaults {
  const char* mode;
  double peak, black, paper;
};
class RequestModeDefaults : public ::testing::TestWithParam<ModeDefaults> {};

TEST_P(RequestModeDefaults, FollowReferenceTable) {
  const auto& d = GetParam();
  auto r = parse(std::string(R"({"display":{"mode":")") + d.mode + R"("}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto& t = r->display.target;
  EXPECT_DOUBLE_EQ(t.peak_nits, d.peak) << d.mode;
  EXPECT_DOUBLE_EQ(t.black_nits, d.black) << d.mode;
  EXPECT_DOUBLE_EQ(t.paper_white_nits, d.paper) << d.mode;
  EXPECT_DOUBLE_EQ(t.ui_white_nits, t.paper_white_nits) << "ui white defaults to paper white (§1.4)";
  EXPECT_DOUBLE_EQ(t.sdr_white_nits, t.paper_white_nits) << "sdr white defaults to paper white (§1.4)";
  EXPECT_EQ(t.range, Range::full);
}
INSTANTIATE_TEST_SUITE_P(Reference18, RequestModeDefaults,
                         ::testing::Values(ModeDefaults{"hdr10", 1000, 0.005, 203}, ModeDefaults{"hlg", 1000, 0, 203},
                                           ModeDefaults{"scrgb", 1000, 0, 203}, ModeDefaults{"sdr", 100, 0.1, 100},
                                           ModeDefaults{"sdr-bt1886", 100, 0.1, 100}));

TEST(Request, SdrPaperWhiteFollowsAGivenPeak) {
  // §1.8: SDR paper white "= peak"; UI and SDR white follow paper white (§1.4).
  auto r = parse(R"({"display":{"mode":"sdr","peak_nits":250}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->display.target.paper_white_nits, 250);
  EXPECT_DOUBLE_EQ(r->display.target.ui_white_nits, 250);
  // An HDR mode keeps 203 whatever the peak.
  r = parse(R"({"display":{"mode":"hdr10","peak_nits":600,"ui_white_nits":300}})");
  ASSERT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r->display.target.paper_white_nits, 203);
  EXPECT_DOUBLE_EQ(r->display.target.ui_white_nits, 300);
  EXPECT_DOUBLE_EQ(r->display.target.sdr_white_nits, 203);
}

TEST(Request, ExposureCompensationTopLevelAndNested) {
  auto r = parse(R"({"exposure_comp_ev":1.5})");
  ASSERT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r->exposure.compensation_ev, 1.5);
  r = parse(R"({"exposure":{"compensation_ev":-2,"mode":"histogram","percentile":95}})");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->exposure.compensation_ev, -2);
  EXPECT_EQ(r->exposure.mode, exposure::Mode::histogram);
  EXPECT_DOUBLE_EQ(r->exposure.percentile, 95);
  r = parse(R"({"exposure_comp_ev":1,"exposure":{"compensation_ev":2}})");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.conflict");
  // An EV100 alone means camera exposure, as on the command line.
  r = parse(R"({"exposure":{"ev100":14.966}})");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->exposure.mode, exposure::Mode::camera);
}

struct Bad {
  const char* body;
  const char* code;
  const char* field;
};
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
        Bad{R"({"width":256)", "request.syntax", ""}, Bad{"", "request.syntax", ""},
        Bad{"[1,2]", "request.type", ""}, Bad{"null", "request.type", ""},
        Bad{R"({"width":"256"})", "request.type", "width"}, Bad{R"({"width":25.5})", "request.type", "width"},
        Bad{R"({"width":0})", "request.limit", "width"}, Bad{R"({"width":100000})", "request.limit", "width"},
        Bad{R"({"width":1e300})", "request.limit", "width"},
        Bad{R"({"width":18446744073709551615})", "request.limit", "width"},
        Bad{R"({"width":1e400})", "request.value", "width"},
        Bad{R"({"display":{"peak_nits":5e551}})", "request.value", "display.peak_nits"},
        Bad{R"({"ui":{"png_base64":""}})", "request.value", "ui.png_base64"},
        Bad{R"({"width":7680,"height":4320,"samples":1000})", "request.limit", "samples"},
        Bad{R"({"widht":256})", "request.unknown_field", "widht"},
        Bad{R"({"display":{"mode":"hdr10","peak":1000}})", "request.unknown_field", "display.peak"},
        Bad{R"({"display":{"mode":"hdr11"}})", "request.value", "display.mode"},
        Bad{R"({"display":{"peak_nits":-5}})", "request.value", "display.peak_nits"},
        Bad{R"({"display":{"peak_nits":20000}})", "request.value", "display.peak_nits"},
        Bad{R"({"display":{"peak_nits":"1000"}})", "request.type", "display.peak_nits"},
        Bad{R"({"display":"automatic"})", "request.value", "display"},
        Bad{R"({"display":{"range":"studio"}})", "request.value", "display.range"},
        Bad{R"({"tone":{"curve":5}})", "request.type", "tone.curve"},
        Bad{R"({"tone":{"params":{"w":"x"}}})", "request.type", "tone.params.w"},
        Bad{R"({"tone":{"apply":"sideways"}})", "request.value", "tone.apply"},
        Bad{R"({"exposure":{"mode":"automatic"}})", "request.value", "exposure.mode"},
        Bad{R"({"exposure":{"iso":0}})", "request.value", "exposure.iso"},
        Bad{R"({"camera":{"position":[1,2]}})", "request.type", "camera.position"},
        Bad{R"({"camera":{"fov_y_deg":180}})", "request.value", "camera.fov_y_deg"},
        Bad{R"({"scene":42})", "request.type", "scene"},
        Bad{R"({"scene":"a","gltf":"b.gltf"})", "request.conflict", "scene"},
        Bad{R"({"scene":{"lights":[]},"formats":["png"]})", "request.conflict", "formats"},
        Bad{R"({"dump":true,"formats":["tiff"]})", "request.value", "formats"},
        Bad{R"({"dump":true,"name":"../evil"})", "request.value", "name"},
        Bad{R"({"dump":true,"name":".hidden"})", "request.value", "name"},
        Bad{R"({"dump":"yes"})", "request.type", "dump"},
        Bad{R"({"gltf":"x.gltf"})", "path.forbidden", "gltf"},
        Bad{R"({"ui":{"png_base64":"@@@@"}})", "request.value", "ui.png_base64"},
        Bad{R"({"ui":{"x":1}})", "request.value", "ui.path"},
        Bad{R"({"timeout_s":0})", "request.value", "timeout_s"},
        Bad{R"({"input":"relative"})", "request.unknown_field", "input"}));

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

TEST(Request, NestingDepthIsRefusedBeforeParsing) {
  const std::string deep = std::string(100, '[') + std::string(100, ']');
  auto r = parse(deep);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.depth");
  EXPECT_EQ(json_nesting_depth(R"({"a":"[[[[{{{{","b":[1,[2]]})"), 3) << "brackets inside strings do not count";
}

// nlohmann's lexer ends its input at a NUL byte: without the bounded parse, what followed
// one was ignored and the request before it taken as the whole body (issue 14).
TEST(Request, NulByteInTheBodyIsRefused) {
  std::string body = R"({"width":64})";
  body += '\0';
  body += R"({"height":"not even looked at")";
  auto r = parse(body);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.syntax");
  EXPECT_NE(r.error().message.find("NUL byte at byte 12"), std::string::npos) << r.error().message;
}

// Every entry point: the multipart 'request' part is bounded like a body (issue 14: a part
// nested 100 000 deep crashed the daemon).
TEST(Request, MultipartRequestPartIsBoundedLikeABody) {
  Limits limits;
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  std::vector<Part> parts = {{"image", "a.exr", "image/x-exr", "EXR"}, {"request", "", "application/json", deep}};
  auto up = split_encode_upload(parts, limits);
  ASSERT_FALSE(up.ok());
  EXPECT_EQ(up.error().code, "request.depth");
  EXPECT_EQ(up.error().field, "request");
  parts = {{"image", "", "", "EXR"}, {"request", "", "", std::string("{}\0x", 4)}};
  EXPECT_EQ(split_encode_upload(parts, limits).error().code, "request.syntax");
  parts = {{"image", "", "", "EXR"}, {"request", "", "", R"({"display":{"peak_nits":1e999}})"}};
  EXPECT_EQ(split_encode_upload(parts, limits).error().field, "display.peak_nits");
  parts = {{"image", "", "", "EXR"}, {"request", "", "", "[1]"}};
  EXPECT_EQ(split_encode_upload(parts, limits).error().code, "request.type");
  parts = {{"image", "", "", "EXR"}, {"request", "", "", "{}"}, {"request", "", "", "{}"}};
  EXPECT_EQ(split_encode_upload(parts, limits).error().code, "request.unknown_field") << "one request part";
  parts = {{"imag\xff", "", "", "EXR"}};
  auto bad = split_encode_upload(parts, limits);
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(io::is_valid_utf8(bad.error().field)) << "a field the JSON error body can carry";
  parts = {{"request", "", "", "{}"}};
  EXPECT_EQ(split_encode_upload(parts, limits).error().field, "image");
  parts = {{"image", "", "", "EXR"}, {"request", "", "", R"({"display":{"mode":"hlg"}})"}};
  auto ok = split_encode_upload(parts, limits);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->exr, "EXR");
  EXPECT_EQ(ok->options["display"]["mode"], "hlg");
}

TEST(Request, TooManyLightsInAnInlineScene) {
  std::string lights;
  for (int i = 0; i < 300; ++i) lights += std::string(i ? "," : "") + "{}";
  auto r = parse(R"({"scene":{"lights":[)" + lights + "]}}");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.limit");
  EXPECT_EQ(r.error().field, "scene.lights");
}

TEST(Request, EncodeEndpointTakesNoSceneFields) {
  auto r = parse(R"({"width":10})", Endpoint::encode);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.unknown_field");
  r = parse(R"({"input":"absolute","display":{"mode":"hlg"}})", Endpoint::encode);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->input, "absolute");
}

TEST(Request, CanonicalJsonIsTheSameForEquivalentRequests) {
  auto a = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1000}})");
  auto b = parse(R"({"display":{"peak_nits":1000.0,"mode":"hdr10"},"height":144,"width":256})");
  auto c = parse(R"({"width":256,"height":144,"display":{"mode":"hdr10","peak_nits":1001}})");
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->canonical().dump(), b->canonical().dump());
  EXPECT_NE(a->canonical().dump(), c->canonical().dump());
}

// ---- paths --------------------------------------------------------------------------

TEST(Paths, ResolvedInsideTheRootOnly) {
  testing::TempDir tmp;
  const fs::path root = tmp / "assets";
  fs::create_directories(root / "scenes");
  std::ofstream(root / "scenes/a.json") << "{}";
  std::ofstream(tmp / "secret.txt") << "secret";
  fs::create_symlink(tmp / "secret.txt", root / "escape.json");
  fs::create_symlink(root / "scenes/a.json", root / "inside.json");

  auto ok = resolve_in_root(root, "scenes/a.json", "scene_file");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(*ok, fs::canonical(root / "scenes/a.json"));
  EXPECT_TRUE(resolve_in_root(root, (root / "scenes/a.json").string(), "f").ok()) << "absolute but inside";
  EXPECT_TRUE(resolve_in_root(root, "inside.json", "f").ok()) << "a symlink that stays inside";

  const struct {
    std::string path;
    const char* code;
  } bad[] = {{"../secret.txt", "path.forbidden"},
             {"scenes/../../secret.txt", "path.forbidden"},
             {"scenes/../a.json", "path.forbidden"},  // ".." is refused even when it stays inside
             {(tmp / "secret.txt").string(), "path.forbidden"},
             {"/etc/passwd", "path.forbidden"},
             {"escape.json", "path.forbidden"},
             {"scenes/missing.json", "path.not_found"},
             {"scenes", "path.not_found"},
             {"", "path.invalid"},
             {std::string("a\0b", 3), "path.invalid"}};
  for (const auto& b : bad) {
    auto r = resolve_in_root(root, b.path, "gltf");
    ASSERT_FALSE(r.ok()) << b.path;
    EXPECT_EQ(r.error().code, b.code) << b.path << ": " << r.error().message;
    EXPECT_EQ(r.error().field, "gltf");
  }
  EXPECT_EQ(resolve_in_root({}, "a.json", "f").error().code, "path.forbidden") << "no root configured";
}

TEST(Paths, WithinComparesWholeComponents) {
  EXPECT_TRUE(is_within("/srv/assets", "/srv/assets/x.gltf"));
  EXPECT_TRUE(is_within("/srv/assets/", "/srv/assets/x.gltf"));
  EXPECT_FALSE(is_within("/srv/assets", "/srv/assets2/x.gltf"));
  EXPECT_FALSE(is_within("/srv/assets", "/srv"));
}

TEST(Paths, RequestFieldsAreResolved) {
  testing::TempDir tmp;
  std::ofstream(tmp / "grade.cube") << "LUT_3D_SIZE 2\n";
  auto r = parse(R"({"grade":{"lut":"grade.cube","placement":"scene","shaper":"log2"}})", Endpoint::render, tmp.path());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->grade->lut, fs::canonical(tmp / "grade.cube"));
  r = parse(R"({"grade":{"lut":"../grade.cube"}})", Endpoint::render, tmp.path());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "path.forbidden");
  EXPECT_EQ(r.error().field, "grade.lut");
}

TEST(Paths, DumpNames) {
  EXPECT_TRUE(validate_dump_name("frame-01_a.b").ok());
  for (const char* bad : {"", ".x", "a/b", "a\\b", "..", "a b", "x\n"}) EXPECT_FALSE(validate_dump_name(bad).ok()) << bad;
  EXPECT_FALSE(validate_dump_name(std::string(101, 'a')).ok());
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

// ---- query parameters (POST /v1/encode) --------------------------------------------------

TEST(Query, MapsToTheSameJsonFields) {
  auto j = query_to_request_json({{"mode", "sdr"}, {"peak_nits", "250"}, {"curve", "reinhard"}, {"dump", ""}});
  ASSERT_TRUE(j.ok()) << j.error().message;
  EXPECT_EQ((*j)["display"]["mode"], "sdr");
  EXPECT_EQ((*j)["display"]["peak_nits"], 250);
  EXPECT_EQ((*j)["tone"]["curve"], "reinhard");
  EXPECT_EQ((*j)["dump"], true);
  EXPECT_EQ(query_to_request_json({{"peak", "1"}}).error().code, "request.unknown_field");
  EXPECT_EQ(query_to_request_json({{"peak_nits", "lots"}}).error().code, "request.type");
  EXPECT_EQ(query_to_request_json({{"peak_nits", "1"}, {"peak_nits", "2"}}).error().code, "request.conflict");
}

// Query parameters arrive percent-decoded: %ff is a byte that is not UTF-8 and %00 a NUL.
// Every parameter name, and a value for each, is refused with 400 request.query (issue 14:
// mode=%ff answered 500 when the JSON library met the string).
TEST(Query, InvalidUtf8AndNulAreRefusedInEveryParameter) {
  for (const auto& p : query_params()) {
    for (const std::string& value : std::vector<std::string>{"\xff", "a\xc0\xaf" "b", std::string("hdr10\0x", 7), "\xed\xa0\x80"}) {
      auto r = check_query({{std::string(p.name), value}});
      ASSERT_FALSE(r.ok()) << p.name;
      EXPECT_EQ(r.error().code, "request.query");
      EXPECT_EQ(r.error().field, p.name);
      EXPECT_EQ(http_status(r.error()), 400u);
    }
    EXPECT_TRUE(check_query({{std::string(p.name), "1000"}}).ok()) << p.name;
  }
  EXPECT_EQ(check_query({{"mo\xff" "de", "hdr10"}}).error().code, "request.query") << "names too";
  EXPECT_TRUE(io::is_valid_utf8(check_query({{"mo\xff" "de", "x"}}).error().field));
  std::vector<std::pair<std::string, std::string>> many(kMaxQueryParams + 1, {"mode", "hdr10"});
  EXPECT_EQ(check_query(many).error().code, "request.query");
  EXPECT_EQ(check_query({{"name", std::string(kMaxQueryBytes + 1, 'a')}}).error().code, "request.query");
  EXPECT_TRUE(check_query({{"name", "caf\xc3\xa9"}}).ok()) << "UTF-8 itself is fine";
}

// ---- Accept (RFC 9110 §12.5.1) ---------------------------------------------------------

TEST(Accept, NegotiatesTheFrameFormat) {
  auto pick = [](const char* accept, Mode mode = Mode::hdr10, bool dump = false) {
    std::string a = accept ? accept : "";
    return negotiate_output(accept ? &a : nullptr, mode, dump);
  };
  EXPECT_EQ(*pick(nullptr), OutputKind::png);
  EXPECT_EQ(*pick("*/*"), OutputKind::png);
  EXPECT_EQ(*pick("image/png"), OutputKind::png);
  EXPECT_EQ(*pick("image/x-exr"), OutputKind::exr);
  EXPECT_EQ(*pick("application/octet-stream"), OutputKind::raw);
  EXPECT_EQ(*pick("image/png;q=0.5, image/x-exr"), OutputKind::exr);
  EXPECT_EQ(*pick("image/*;q=0.9, application/octet-stream"), OutputKind::raw);
  EXPECT_EQ(*pick("image/*, image/png;q=0"), OutputKind::exr) << "the most specific range wins";
  EXPECT_EQ(*pick(nullptr, Mode::scrgb), OutputKind::exr) << "scrgb has no PNG form";
  EXPECT_EQ(pick("image/png", Mode::scrgb).error().code, "request.not_acceptable");
  EXPECT_EQ(pick("text/html").error().code, "request.not_acceptable");
  EXPECT_EQ(*pick("image/png, application/json", Mode::hdr10, true), OutputKind::json_dump);
  EXPECT_EQ(pick("image/png", Mode::hdr10, true).error().code, "request.not_acceptable");
}

// ---- error codes -> HTTP status ---------------------------------------------------------

TEST(WireError, StatusPerCode) {
  const std::pair<const char*, unsigned> table[] = {
      {"request.syntax", 400},     {"request.unknown_field", 400}, {"request.limit", 400},
      {"request.too_large", 413},  {"request.media_type", 415},    {"request.not_acceptable", 406},
      {"request.unauthorized", 401}, {"request.not_found", 404},   {"request.method", 405},
      {"request.timeout", 504},    {"path.forbidden", 403},        {"path.not_found", 404},
      {"queue.full", 503},         {"server.draining", 503},       {"renderer.unavailable", 503},
      {"exr.truncated", 422},      {"tonemap.unknown", 422},       {"io.write", 500},
      {"io.no_space", 507},        {"edid.too_short", 422},        {"edid.bad_header", 422},
      {"file.too_large", 422},     {"request.query", 400},         {"request.length_required", 411},
      {"request.header_timeout", 408}, {"request.body_timeout", 408}, {"server.busy", 503},
      {"queue.memory", 503},       {"request.memory", 400},        {"request.depth", 400},
      {"internal", 500},           {"something.new", 500}};
  for (const auto& [code, status] : table) EXPECT_EQ(http_status(make_error(code, "m")), status) << code;
  const auto body = nlohmann::json::parse(error_body(make_error("request.type", "width: bad", "width")));
  EXPECT_EQ(body["error"]["code"], "request.type");
  EXPECT_EQ(body["error"]["message"], "width: bad");
  EXPECT_EQ(body["error"]["field"], "width");
  EXPECT_FALSE(nlohmann::json::parse(error_body(make_error("x", "y")))["error"].contains("field"));
}

}  // namespace
}  // namespace hdrd::daemon

// The daemon's transport pieces: paths confined to the asset root, Accept negotiation (RFC
// 9110 §12.5.1) over the output table, the input bounds of query parameters and multipart
// parts (issue 14), and the one error-status table — with a test that
// collects every error code the code base can produce and fails on any without a status.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <nlohmann/json.hpp>

#include "daemon/http/accept.hpp"
#include "daemon/http/input_bounds.hpp"
#include "daemon/api/paths.hpp"
#include "daemon/http/wire_error.hpp"
#include "job/settings.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::daemon {
namespace {

namespace fs = std::filesystem;
using job::Output;

TEST(Paths, ResolvedInsideTheRootOnly) {
  testing::TempDir tmp;
  const fs::path root = tmp / "assets";
  fs::create_directories(root / "scenes");
  std::ofstream(root / "scenes/a.json") << "{}";
  std::ofstream(tmp / "secret.txt") << "secret";
  fs::create_symlink(tmp / "secret.txt", root / "escape.json");
  fs::create_symlink(root / "scenes/a.json", root / "inside.json");

  auto ok = resolve_in_root(root, "scenes/a.json", "scene");
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
    auto r = resolve_in_root(root, b.path, "scene");
    ASSERT_FALSE(r.ok()) << b.path;
    EXPECT_EQ(r.error().code, b.code) << b.path << ": " << r.error().message;
    EXPECT_EQ(r.error().field, "scene");
  }
  EXPECT_EQ(resolve_in_root({}, "a.json", "f").error().code, "path.forbidden") << "no root configured";
}

TEST(Paths, WithinComparesWholeComponents) {
  EXPECT_TRUE(is_within("/srv/assets", "/srv/assets/x.gltf"));
  EXPECT_TRUE(is_within("/srv/assets/", "/srv/assets/x.gltf"));
  EXPECT_FALSE(is_within("/srv/assets", "/srv/assets2/x.gltf"));
  EXPECT_FALSE(is_within("/srv/assets", "/srv"));
}

TEST(Accept, NegotiatesTheFrameFormat) {
  auto pick = [](const char* accept, Mode mode = Mode::hdr10) {
    std::string a = accept ? accept : "";
    return negotiate_output(accept ? &a : nullptr, mode);
  };
  EXPECT_EQ(*pick(nullptr), Output::png);
  EXPECT_EQ(*pick("*/*"), Output::png);
  EXPECT_EQ(*pick("image/png"), Output::png);
  EXPECT_EQ(*pick("image/x-exr"), Output::exr);
  EXPECT_EQ(*pick("application/octet-stream"), Output::raw);
  EXPECT_EQ(*pick("image/png;q=0.5, image/x-exr"), Output::exr);
  EXPECT_EQ(*pick("image/*;q=0.9, application/octet-stream"), Output::raw);
  EXPECT_EQ(*pick("image/*, image/png;q=0"), Output::exr) << "the most specific range wins";
  EXPECT_EQ(*pick(nullptr, Mode::scrgb), Output::exr) << "scrgb has no PNG form";
  EXPECT_EQ(pick("image/png", Mode::scrgb).error().code, "request.not_acceptable");
  EXPECT_EQ(pick("text/html").error().code, "request.not_acceptable");
  // Stills: image/jpeg is the gain-map JPEG in HDR modes (a render or an EXR: they have
  // scene light for the SDR rendition), the plain JPEG in sdr.
  EXPECT_EQ(*pick("image/avif"), Output::avif);
  EXPECT_EQ(*pick("image/jxl"), Output::jxl);
  EXPECT_EQ(*pick("image/jpeg"), Output::jpeg_gainmap);
  EXPECT_EQ(*pick("image/jpeg", Mode::hlg), Output::jpeg_gainmap);
  EXPECT_EQ(*pick("image/jpeg", Mode::sdr), Output::jpeg);
  EXPECT_EQ(pick("image/avif", Mode::scrgb).error().code, "request.not_acceptable");
  std::string jpeg = "image/jpeg";
  EXPECT_EQ(negotiate_output(&jpeg, Mode::hdr10, job::Source::pattern).error().code, "request.not_acceptable")
      << "a pattern has no scene light for a gain map";
  std::string a = "image/png, application/json";
  EXPECT_TRUE(accepts_json(&a).ok());
  a = "image/png";
  EXPECT_EQ(accepts_json(&a).error().code, "request.not_acceptable");
  EXPECT_TRUE(accepts_json(nullptr).ok());
}

TEST(WireError, StatusPerCode) {
  const std::pair<const char*, unsigned> table[] = {
      {"request.syntax", 400},       {"request.unknown_field", 400}, {"request.limit", 400},
      {"request.too_large", 413},    {"request.media_type", 415},    {"request.not_acceptable", 406},
      {"request.unauthorized", 401}, {"request.not_found", 404},     {"request.method", 405},
      {"request.timeout", 504},      {"path.forbidden", 403},        {"path.not_found", 404},
      {"queue.full", 503},           {"server.draining", 503},       {"renderer.unavailable", 503},
      {"exr.truncated", 422},        {"tonemap.unknown", 422},       {"edid.bad_header", 422},
      {"edid.too_short", 422},       {"io.write", 500},              {"internal", 500},
      // issue 14: the client's faults are 4xx, a full disk 507, a busy daemon 503
      {"io.no_space", 507},          {"file.too_large", 422},        {"request.query", 400},
      {"request.length_required", 411}, {"request.header_timeout", 408}, {"request.body_timeout", 408},
      {"server.busy", 503},          {"queue.memory", 503},          {"request.memory", 400},
      {"request.depth", 400},
      // a missing FFmpeg on the daemon's machine is the daemon's fault; what a codec cannot do is the request's
      {"video.libav", 500},          {"video.codec", 422},
      // issue 28: a malformed target or framing is the client's
      {"request.target", 400},       {"request.content_length", 400},
      // issue 28, the file model (docs/api.md "Security"): a link or hard link refused is 403, a
      // FIFO or device 422, a result replaced since the job wrote it 410, a colliding name 422
      {"path.symlink", 403},         {"path.hard_link", 403},        {"path.not_regular", 422},
      {"job.file_changed", 410},     {"name.collision", 422},
      // issue 28.9: a malformed Radiance map is the request's, as a malformed EXR is
      {"hdr.size", 422},             {"hdr.rle", 422},               {"hdr.truncated", 422},
      {"hdr.resolution", 422},       {"hdr.file", 422},              {"hdr_metadata.x", 422}};
  for (const auto& [code, status] : table) EXPECT_EQ(http_status(make_error(code, "m")), status) << code;
  EXPECT_FALSE(status_of("something.new")) << "an unknown family has no status";
  EXPECT_EQ(http_status(make_error("something.new", "m")), 500u);
  const auto body = nlohmann::json::parse(error_body(make_error("request.type", "width: bad", "width")));
  EXPECT_EQ(body["error"]["code"], "request.type");
  EXPECT_EQ(body["error"]["message"], "width: bad");
  EXPECT_EQ(body["error"]["field"], "width");
  EXPECT_FALSE(nlohmann::json::parse(error_body(make_error("x", "y")))["error"].contains("field"));
}

// ---- input bounds (issue 14) ----------------------------------------------------------

// Every entry point: the multipart 'request' part is bounded like a body (issue 14: a part
// nested 100 000 deep crashed the daemon).
TEST(InputBounds, MultipartRequestPartIsBoundedLikeABody) {
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

// Query parameters arrive percent-decoded: %ff is a byte that is not UTF-8 and %00 a NUL.
// Every parameter name, and a value for each, is refused with 400 request.query (issue 14:
// mode=%ff answered 500 when the JSON library met the string).
TEST(InputBounds, InvalidUtf8AndNulAreRefusedInEveryQueryParameter) {
  for (const auto& p : job::settings()) {
    if (p.query.empty()) continue;
    const std::string name(p.query);
    for (const std::string& value :
         std::vector<std::string>{"\xff", "a\xc0\xaf" "b", std::string("hdr10\0x", 7), "\xed\xa0\x80"}) {
      auto r = check_query({{name, value}});
      ASSERT_FALSE(r.ok()) << name;
      EXPECT_EQ(r.error().code, "request.query");
      EXPECT_EQ(r.error().field, name);
      EXPECT_EQ(http_status(r.error()), 400u);
    }
    EXPECT_TRUE(check_query({{name, "1000"}}).ok()) << name;
  }
  EXPECT_EQ(check_query({{"mo\xff" "de", "hdr10"}}).error().code, "request.query") << "names too";
  EXPECT_TRUE(io::is_valid_utf8(check_query({{"mo\xff" "de", "x"}}).error().field));
  std::vector<std::pair<std::string, std::string>> many(kMaxQueryParams + 1, {"mode", "hdr10"});
  EXPECT_EQ(check_query(many).error().code, "request.query");
  EXPECT_EQ(check_query({{"name", std::string(kMaxQueryBytes + 1, 'a')}}).error().code, "request.query");
  EXPECT_TRUE(check_query({{"name", "caf\xc3\xa9"}}).ok()) << "UTF-8 itself is fine";
}

// Issue 28 item 5: the target as sent. Raw control bytes anywhere; percent-encoded ones in
// the path (the query's are check_query's, which names the parameter); the rest stays.
TEST(InputBounds, ControlBytesInTheTargetAreRefused) {
  for (const std::string& bad : {std::string("/v1/status\0x", 12), std::string("/v1/\x1b[2J"), std::string("/v1/\x7f"),
                                std::string("/v1/a\tb"), std::string("/v1/status?x=\x01"), std::string("/v1/status%00x"),
                                std::string("/v1/jobs/j1%00/result"), std::string("/v1/x%0a"), std::string("/v1/x%0D%0A"),
                                std::string("/v1/x%1B"), std::string("/v1/x%7f"), std::string("/v1/x%1f")}) {
    auto r = check_request_target(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, "request.target");
    EXPECT_EQ(http_status(r.error()), 400u);
  }
  for (const std::string good : {"/v1/status", "/v1/%73tatus", "/v1/x%20y", "/v1/x%7e", "/v1/x%80", "/v1/x%",
                                 "/v1/x%0", "/v1/x%zz", "/v1/status?x=%01", "/v1/status?mode=hdr10%0a"})
    EXPECT_TRUE(check_request_target(good).ok()) << good;
  auto q = check_query({{"mode", "hdr10\n"}});
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.error().code, "request.query");
  EXPECT_EQ(q.error().field, "mode");
}

// Every code the code base makes — make_error("...") anywhere, the request parser's
// fail("..."), and codes assigned to an Error — has a status in the one table, so that no
// client fault falls through to 500 by omission.
TEST(WireError, EveryCodeInTheCodeBaseHasAStatus) {
  // (Not `x.fail("field", ...)`: member helpers that take a field first.)
  const std::regex made(R"re((?:^|[^.>\w])(?:make_error|fail)\(\s*"([a-z0-9_]+(?:\.[a-z0-9_]+)*)")re");
  const std::regex assigned(R"re(\.code\s*=\s*"([a-z0-9_]+(?:\.[a-z0-9_]+)*)")re");
  std::set<std::string> codes, missing;
  for (const char* dir : {"encode", "shading", "display", "patterns", "job", "daemon", "tools"}) {
    for (const auto& e : fs::recursive_directory_iterator(testing::source_dir() / dir)) {
      const auto ext = e.path().extension();
      if (ext != ".cpp" && ext != ".hpp") continue;
      const std::string text = testing::read_file(e.path());
      for (const auto* re : {&made, &assigned})
        for (std::sregex_iterator it(text.begin(), text.end(), *re), end; it != end; ++it) codes.insert((*it)[1]);
    }
  }
  ASSERT_GT(codes.size(), 100u) << "the scan found too few codes: is the source tree there?";
  for (const auto& c : codes)
    if (!status_of(c)) missing.insert(c);
  std::string list;
  for (const auto& c : missing) list += " " + c;
  EXPECT_TRUE(missing.empty()) << "codes without a status in daemon/http/wire_error.cpp:" << list;
}

}  // namespace
}  // namespace hdrd::daemon

// The daemon's transport pieces: paths confined to the asset root, Accept negotiation (RFC
// 9110 §12.5.1) over the output table, and the one error-status table — with a test that
// collects every error code the code base can produce and fails on any without a status.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <nlohmann/json.hpp>

#include "daemon/accept.hpp"
#include "daemon/paths.hpp"
#include "daemon/wire_error.hpp"
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
      {"edid.too_short", 422},       {"io.write", 500},              {"internal", 500}};
  for (const auto& [code, status] : table) EXPECT_EQ(http_status(make_error(code, "m")), status) << code;
  EXPECT_FALSE(status_of("something.new")) << "an unknown family has no status";
  EXPECT_EQ(http_status(make_error("something.new", "m")), 500u);
  const auto body = nlohmann::json::parse(error_body(make_error("request.type", "width: bad", "width")));
  EXPECT_EQ(body["error"]["code"], "request.type");
  EXPECT_EQ(body["error"]["message"], "width: bad");
  EXPECT_EQ(body["error"]["field"], "width");
  EXPECT_FALSE(nlohmann::json::parse(error_body(make_error("x", "y")))["error"].contains("field"));
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
  EXPECT_TRUE(missing.empty()) << "codes without a status in daemon/wire_error.cpp:" << list;
}

}  // namespace
}  // namespace hdrd::daemon

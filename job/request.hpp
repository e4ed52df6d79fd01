// A frame request: which source (render / encode / pattern) and the validated value of
// every setting (job/settings.hpp), from a JSON body, CLI flags or query parameters — three
// spellings of one request, parsed by one parser. Pure: no GL, no sockets; the only
// file-system access is the front end's path resolver. Fuzzed by tests/fuzz/request_fuzz.cpp.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"
#include "encode/io/json_text.hpp"
#include "encode/result.hpp"
#include "job/settings.hpp"

namespace hdrd::job {

// Request limits (the daemon's config [limits]; the CLI uses these defaults). Every one
// is checked before anything is allocated for the request.
struct Limits {
  int max_width = 7680;
  int max_height = 4320;
  std::int64_t max_pixels = 7680LL * 4320LL;
  int max_samples = 64;
  int max_lights = 256;
  std::size_t max_body_bytes = 16u << 20;     // JSON requests (UI uploads included)
  std::size_t max_upload_bytes = 256u << 20;  // /v1/encode EXR uploads
  std::size_t max_ui_bytes = 8u << 20;        // decoded UI PNG
  int max_json_depth = 32;
  double max_request_seconds = 120;           // queue wait + render + encode
};

// How a front end spells the request, so errors name what the user wrote.
enum class Spelling { json, cli, query };

// Resolves a path setting: the CLI takes it as given; the daemon confines it to its asset
// root (and refuses it when there is none). Errors carry their code (path.forbidden, ...).
using PathResolver = std::function<Result<std::filesystem::path>(std::string_view requested, const std::string& field)>;

struct ParseContext {
  Source source = Source::render;
  Spelling spelling = Spelling::json;
  Reach reach = Reach::everywhere;  // Reach::daemon or Reach::cli: which transport-only settings exist
  Limits limits;
  PathResolver resolve_path;        // unset: paths are refused
  bool sequence = false;            // a sequence request: the settings marked `sequence` exist
};

// A render's scene: a built-in name, a file (resolved), or an inline JSON scene.
struct SceneRef {
  enum class Kind { builtin, file, inline_json };
  Kind kind = Kind::builtin;
  std::string name;              // built-in
  std::filesystem::path path;    // file
  nlohmann::json inline_scene;   // inline
};

struct FrameRequest {
  Source source = Source::render;
  bool sequence = false;                      // parsed as a sequence (job/sequence.hpp)
  // Every setting of the source by path, validated; static defaults filled in; settings
  // with a run-time default (default_doc) are null unless given. Paths are resolved.
  std::map<std::string, nlohmann::json, std::less<>> values;
  std::set<std::string, std::less<>> given;   // the paths the request set
  SceneRef scene;                             // render
  std::vector<std::uint8_t> ui_png;           // decoded ui.png_base64 (empty: none)
  // Every path read through at(): tests check that no setting is parsed and then ignored.
  mutable std::set<std::string, std::less<>> read;

  const nlohmann::json& at(std::string_view path) const;   // throws std::logic_error on a path not in the table
  bool has(std::string_view path) const { return given.count(path) != 0; }
  bool is_null(std::string_view path) const { return at(path).is_null(); }
  double number(std::string_view path) const { return at(path).get<double>(); }
  std::optional<double> optional_number(std::string_view path) const;
  std::int64_t integer(std::string_view path) const { return at(path).get<std::int64_t>(); }
  bool boolean(std::string_view path) const { return at(path).get<bool>(); }
  std::string text(std::string_view path) const;  // "" when null
  std::vector<std::string> list(std::string_view path) const;

  // The request with every default filled in, as nested JSON with sorted keys: identical
  // requests have identical canonical JSON (the coalescing key; the sidecar's "request").
  nlohmann::json canonical() const;
};

// The levels the request sets (unset: not given), for the levels resolver.
LevelSettings request_levels(const FrameRequest& r);

// The limits' bounds for a JSON request text (a body, a multipart 'request' part): codes
// request.too_large, request.depth, request.syntax (malformed, a NUL byte, ill-formed
// UTF-8), request.value (a number beyond double's range, naming its field); see
// io::parse_json_bounded: depth is bounded while the text is read, never after.
io::JsonBounds request_json_bounds(const Limits& limits, std::string_view what = "request");

// A bounded JSON text that must be an object (request.type otherwise).
Result<nlohmann::json> parse_json_object_bounded(std::string_view text, const Limits& limits,
                                                 std::string_view what = "request");

// Parses a JSON body (parse_json_object_bounded), or an already parsed object.
// Errors: request.too_large, request.syntax, request.depth, request.type,
// request.unknown_field, request.value, request.limit, request.conflict, path.* — with the
// offending field's JSON path, and a message naming it as the user spelled it.
Result<FrameRequest> parse_request(std::string_view body, const ParseContext& ctx);
Result<FrameRequest> parse_request_json(const nlohmann::json& body, const ParseContext& ctx);

// The JSON request a set of CLI values stands for: {flag or composite flag, [values...]}
// in the order given (repeated flags keep every value). Errors name the flag.
Result<nlohmann::json> cli_to_request_json(const std::vector<std::pair<std::string, std::string>>& flags);

// The JSON request a query string stands for (POST /v1/encode?mode=hdr10&peak_nits=1000).
Result<nlohmann::json> query_to_request_json(const std::vector<std::pair<std::string, std::string>>& query);

// The label of a setting as a front end shows it: "--peak" on the CLI, "peak_nits" in a
// query string, "display.peak_nits" in JSON.
std::string label(std::string_view path, Spelling spelling);

// Decodes standard base64 (RFC 4648 §4, padding optional, no line breaks).
Result<std::vector<std::uint8_t>> decode_base64(std::string_view text, std::size_t max_bytes);

}  // namespace hdrd::job

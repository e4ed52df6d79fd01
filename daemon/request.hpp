// The daemon's request model: a JSON body (POST /v1/render, /v1/encode, /v1/pattern,
// /v1/selftest) parsed and validated into a typed request, then mapped to
// hdrd::EncodeSettings. Pure: no sockets,
// no GL; the only file-system access is resolving paths inside the configured asset root.
// Fuzzed by tests/fuzz/request_fuzz.cpp.
//
// Field names follow REFERENCE.md §1.9 (display.mode, display.peak_nits, ...); defaults
// follow §1.8: hdrd::default_target(mode), then the request's overrides.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"
#include "encode/tone/exposure.hpp"
#include "encode/grade/grade.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon {

// Per-request limits (config [limits]); every one is checked before any allocation.
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

// Render defaults (config [render]) used when a request is silent.
struct RenderDefaults {
  std::string scene = "material-grid";
  int width = 1280;
  int height = 720;
  int samples = 1;
};

enum class Endpoint { render, encode, pattern };

struct ParseContext {
  Endpoint endpoint = Endpoint::render;
  Limits limits;
  RenderDefaults defaults;
  std::filesystem::path asset_root;  // empty: requests may not name files
};

struct SceneSpec {
  enum class Kind { builtin, inline_json, scene_file, gltf };
  Kind kind = Kind::builtin;
  std::string name;                  // builtin scene name
  nlohmann::json inline_scene;       // the JSON scene format, passed to the renderer
  std::filesystem::path path;        // scene_file / gltf, resolved inside the asset root
};

struct CameraSpec {
  std::optional<std::array<double, 3>> position;
  std::optional<std::array<double, 3>> target;
  std::optional<double> fov_y_deg;    // vertical field of view
};

struct DisplaySpec {
  bool auto_detect = false;                 // "display": "auto": the attached display's EDID
  std::filesystem::path edid_path;          // "display": {"edid": "..."}: an EDID file in the asset root
  DisplayTarget target = default_target(Mode::hdr10);
  // Fields the request set explicitly (they override what a display profile says).
  std::vector<std::string> given;
};

struct ToneSpec {
  std::string curve;                        // empty: the mode's default
  std::map<std::string, double> params;
  std::string apply;                        // empty: the curve's default
};

struct GradeSpec {
  std::filesystem::path lut;                // resolved inside the asset root
  std::string shaper;                       // empty: default
  std::string placement = "display";
  bool trilinear = false;
};

struct UiSpec {
  std::filesystem::path path;               // PNG in the asset root, or
  std::vector<std::uint8_t> png;            // an uploaded PNG (base64 in the request)
  int x = 0, y = 0;
  double scale = 1.0;
  double dim = 0.0;
  bool srgb_blend = false;
  bool premultiplied = false;
};

// POST /v1/pattern: a test pattern by name and its parameters (pattern_catalogue.hpp).
struct PatternSpec {
  std::string name;
  double level_nits = 0;      // window, clipping; 0: the display peak
  double area_percent = 10;   // window
  int steps = 0;              // pq-ramp, near-black, sdr-grey; 0: the pattern's default
  bool labels = true;         // pq-ramp, near-black, clipping, sdr-grey
};

struct Request {
  Endpoint endpoint = Endpoint::render;
  // render only
  SceneSpec scene;
  CameraSpec camera;
  int width = 0, height = 0, samples = 1;  // width and height: pattern too
  // pattern only
  PatternSpec pattern;
  // encode only: how the uploaded EXR's values are meant (empty: from the file)
  std::string input;
  // both
  DisplaySpec display;
  ToneSpec tone;
  exposure::Settings exposure;
  bool exposure_mode_given = false;         // else the endpoint's default (render: light-based)
  std::string gamut = "ictcp";
  std::optional<GradeSpec> grade;
  std::optional<UiSpec> ui;
  bool dump = false;
  std::vector<std::string> formats;         // dump formats; empty: the mode's defaults
  std::string name;                         // dump base name; empty: generated
  bool dither = false;
  std::optional<double> timeout_s;          // shorter than the configured limit

  // The request with every default filled in, keys sorted: identical requests have
  // identical canonical JSON (coalescing key; also echoed in dump sidecars).
  nlohmann::json canonical() const;
};

// Parses and validates a request body. Every failure is an Error whose code is one of
// request.syntax, request.depth, request.type, request.unknown_field, request.value,
// request.limit, request.conflict, path.forbidden, path.not_found, and whose field is the
// dotted path of the offending field ("display.peak_nits").
Result<Request> parse_request(std::string_view body, const ParseContext& ctx);
Result<Request> parse_request_json(const nlohmann::json& body, const ParseContext& ctx);

// POST /v1/selftest: the display-mode suite for one mode (patterns/selftest.hpp). An
// empty body means hdr10 at its default peak.
struct SelftestRequest {
  std::string mode = "hdr10";             // sdr-srgb (or sdr), sdr-bt1886, hdr10, scrgb, hlg
  std::optional<double> peak_nits;        // default: the mode's
  bool render = true;                     // also render the built-in scenes
  std::optional<double> timeout_s;
  nlohmann::json canonical() const;
};
Result<SelftestRequest> parse_selftest_request(std::string_view body, const ParseContext& ctx);

// /v1/encode options given as query parameters (mode=hdr10&peak_nits=1000&curve=bt2390...)
// turned into the JSON request object they stand for. Unknown parameters are errors.
Result<nlohmann::json> query_to_request_json(const std::vector<std::pair<std::string, std::string>>& query);

// The names a request may use for query parameters, with the JSON field each maps to.
struct QueryParam {
  std::string_view name;
  std::string_view json_path;   // "/display/peak_nits"
  enum class Type { string, number, integer, boolean } type;
};
std::span<const QueryParam> query_params();

// Maximum nesting of JSON arrays/objects in `body` (strings skipped); a pre-check so that
// absurdly deep documents are refused before the parser sees them.
int json_nesting_depth(std::string_view body);

// Decodes standard base64 (RFC 4648 §4, padding optional, no line breaks).
Result<std::vector<std::uint8_t>> decode_base64(std::string_view text, std::size_t max_bytes);

}  // namespace hdrd::daemon

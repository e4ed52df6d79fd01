// The settings model: every setting of a frame request described once — its JSON path,
// CLI flag, query parameter, type, unit, range, default and one-line doc. This table drives
// the request parser (JSON bodies, CLI flags, query parameters: job/request.hpp), `--help`,
// the canonical JSON (coalescing key, sidecar), the X-Hdrd-* headers, GET
// /v1/capabilities and docs/settings.md. Adding a setting is one entry here plus its use
// (job/build.cpp).
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace hdrd::job {

// What a request makes a frame from: the three front-end verbs (hdrd render / encode /
// pattern, POST /v1/render / encode / pattern).
enum class Source : unsigned { render = 1, encode = 2, pattern = 4 };
std::string_view to_string(Source s);
using Sources = unsigned;  // a set of Source bits
inline constexpr Sources kRender = 1, kEncode = 2, kPattern = 4;
inline constexpr Sources kSceneReferred = kRender | kEncode;  // exposure, tone, grade, UI
inline constexpr Sources kAllSources = kRender | kEncode | kPattern;
inline constexpr bool applies(Sources set, Source s) { return (set & static_cast<unsigned>(s)) != 0; }

enum class Type {
  number,       // finite double in [min, max]
  integer,      // integer in [min, max]
  boolean,
  choice,       // one of `choices`
  text,         // a string (checked by its use, e.g. a registry name)
  path,         // a file: resolved by the front end (CLI: as given; daemon: inside the asset root)
  vec3,         // three numbers within +-max
  number_map,   // {"name": number, ...} (tone curve parameters)
  choice_list,  // a list of `choices`, no repeats
  base64,       // bytes as RFC 4648 base64 (uploads inside a JSON body)
  scene,        // a built-in scene name, a scene file, or an inline JSON scene object
};
std::string_view to_string(Type t);

// Who may set it: every front end, or only the transport that has it (a dump name only
// exists where the daemon picks the directory; a thread count only where the CLI owns the
// process).
enum class Reach { everywhere, daemon, cli };

struct Setting {
  std::string_view path;                       // JSON path: "display.peak_nits"
  Type type;
  Sources sources;                              // which requests take it
  std::string_view doc;                         // one line, for --help, capabilities, docs
  std::string_view unit = "";                   // "cd/m2", "stops", "s", ""
  double min = 0, max = 0;                      // number, integer; vec3: |element| <= max
  std::span<const std::string_view> choices{};  // choice, choice_list
  std::string_view default_json = "null";       // the static default as JSON ("null": none)
  std::string_view default_doc = "";            // a default decided at run time, in words
  std::string_view flag = "";                   // CLI option ("--peak"); "--no-x" sets false
  std::string_view metavar = "";                // CLI value name ("NITS")
  std::string_view query = "";                  // query parameter of POST /v1/encode
  std::string_view alias = "";                  // another JSON path accepted for it
  std::string_view header = "";                 // X-Hdrd-* header carrying the resolved value
  Reach reach = Reach::everywhere;
  std::size_t max_length = 256;                 // text, path
  bool size_limit = false;                      // above max is request.limit (a size), not request.value
  // Only a sequence request takes it (hdrd render/encode with --frames, a frame pattern or
  // --video; POST /v1/sequences): the time axis of docs/sequences.md.
  bool sequence = false;

  nlohmann::json default_value() const;         // parsed default_json
  std::string default_text() const;             // "1000", "the mode's (...)", for docs
  bool takes(Source s) const { return applies(sources, s); }
};

std::span<const Setting> settings();
// By canonical path or alias; nullptr when unknown.
const Setting* find_setting(std::string_view path);
// True for a path that names a group of settings ("display", "exposure").
bool is_group(std::string_view path);

// CLI options that set several settings at once (`--camera P[:T[:FOV]]`, `--ui-pos X,Y`).
struct Composite {
  std::string_view flag;
  std::string_view metavar;
  std::string_view doc;
  Sources sources;
  std::span<const std::string_view> paths;  // the settings it sets
  // Text -> {"camera": {"position": [...]}}-style JSON fragment, or an error message.
  nlohmann::json (*expand)(std::string_view text, std::string* error);
};
std::span<const Composite> composites();

// Markdown table of every setting (docs/settings.md is this output; a test keeps it so).
std::string settings_markdown();
// GET /v1/capabilities' "settings": every setting with its type, range and default.
nlohmann::json settings_json();

}  // namespace hdrd::job

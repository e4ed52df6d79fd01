// JSON texts from outside (request bodies, multipart parts, scene files, glTF) parsed
// within bounds: size, nesting depth and NUL bytes are checked before or while the
// parser runs, never after. nlohmann's parser is iterative, but printing, copying and
// other libraries' converters (tinygltf's extras) recurse once per level, so a 100 000
// levels deep text must never become a document. The parse runs as SAX events that keep
// the path to the current value, so that a number beyond double's range names its field
// ("lights[2].intensity") instead of leaking the library's text.
#pragma once

#include <cstddef>
#include <string_view>

#include <nlohmann/json.hpp>

#include "encode/result.hpp"

namespace hdrd::io {

struct JsonBounds {
  std::size_t max_bytes = 16u << 20;
  int max_depth = 64;               // nesting of arrays and objects; "{}" is depth 1
  std::string_view what = "JSON";   // what the text is, first word of every message ("request", "scene")
  std::string_view code_prefix = "json.";  // error codes: <prefix>too_large, depth, syntax, value
};

// Parses one JSON text (RFC 8259). Errors: <prefix>too_large (more than max_bytes),
// <prefix>depth (nested deeper than max_depth), <prefix>syntax (malformed, a NUL byte,
// ill-formed UTF-8 in a string; the message gives the byte offset), <prefix>value (a
// number beyond double's range; the field is the value's path).
Result<nlohmann::json> parse_json_bounded(std::string_view text, const JsonBounds& bounds);

// The same checks without building a document, for texts another parser reads (tinygltf).
Result<void> check_json_text(std::string_view text, const JsonBounds& bounds);

// Whether `s` is well-formed UTF-8 (RFC 3629 §3: no overlong forms, no surrogates, at most
// U+10FFFF). JSON strings must be; nlohmann refuses to print one that is not.
bool is_valid_utf8(std::string_view s);

}  // namespace hdrd::io

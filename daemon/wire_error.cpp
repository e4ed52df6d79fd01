#include "daemon/wire_error.hpp"

#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/text.hpp"

namespace hdrd::daemon {
namespace {

struct StatusEntry {
  std::string_view code;  // exact code, or "prefix." for a whole family
  unsigned status;
};

// Sorted by how specific the entry is: exact codes first, then families.
constexpr StatusEntry kStatus[] = {
    {"request.too_large", 413},
    {"request.media_type", 415},
    {"request.not_acceptable", 406},
    {"request.unauthorized", 401},
    {"request.not_found", 404},
    {"request.method", 405},
    {"request.timeout", 504},
    {"request.header_timeout", 408},   // a connection that did not send its request header in time
    {"request.body_timeout", 408},     // ... or its body fast enough
    {"request.length_required", 411},  // chunked request bodies: a body must declare its length
    {"request.cancelled", 499},
    {"path.forbidden", 403},
    {"path.not_found", 404},
    {"queue.full", 503},
    {"queue.memory", 503},            // the in-flight memory budget is taken; retry later
    {"server.busy", 503},             // every connection slot holds a request in progress
    {"io.no_space", 507},             // the dump directory's file system is full (RFC 4918 §11.5)
    {"server.draining", 503},
    {"renderer.unavailable", 503},
    {"pipeline.unavailable", 503},
    {"display.unavailable", 503},
    {"io.", 500},
    {"internal", 500},
    {"request.", 400},
    {"path.", 400},
    // Errors the encode pipeline and parsers report about what the request asked for or
    // uploaded (bad EXR, unknown tone curve, parameter out of range): the request is
    // well-formed but cannot be processed as given.
    {"exr.", 422},
    {"png.", 422},
    {"cube.", 422},
    {"tone.", 422},
    {"tonemap.", 422},
    {"exposure.", 422},
    {"grade.", 422},
    {"display.", 422},
    {"edid.", 422},     // a file named by display.edid that is not a valid EDID
    {"profile.", 422},  // ... or one whose display profile is unusable
    {"file.", 422},     // a file named by a request that cannot be read (too large, unreadable)
    {"ui.", 422},
    {"encode.", 422},
    {"pipeline.", 422},
    {"image.", 422},
    {"scene.", 422},
    {"gltf.", 422},
    {"camera.", 422},
    {"pattern.", 422},
    {"render.", 500},
};

}  // namespace

unsigned http_status(const Error& e) {
  for (const auto& s : kStatus)
    if (s.code.back() != '.' && e.code == s.code) return s.status;
  for (const auto& s : kStatus)
    if (s.code.back() == '.' && std::string_view(e.code).substr(0, s.code.size()) == s.code) return s.status;
  return 500;
}

std::string error_body(const Error& e) {
  // One line whatever the message quotes (the request parser already ensures it; other
  // handlers quote scene names and file errors too).
  nlohmann::json err = {{"code", e.code.empty() ? "internal" : e.code}, {"message", one_line(e.message)}};
  if (!e.field.empty()) err["field"] = e.field;
  // Replace invalid UTF-8 (e.g. from a file name) rather than throw.
  return nlohmann::json{{"error", err}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace hdrd::daemon

// The one place that decides what an Error looks like on the wire: the HTTP status for
// each error code, and the JSON body {"error": {"code", "message", "field"}}.
#pragma once

#include <string>

#include "encode/result.hpp"

namespace hdrd::daemon {

// HTTP status for an error code (docs/api.md, "Errors"). Codes are matched exactly, then
// by their prefix up to the first '.'; anything unknown is 500.
unsigned http_status(const Error& e);

// {"error":{"code":..,"message":..,"field":..}} (field omitted when empty), newline-terminated.
std::string error_body(const Error& e);

}  // namespace hdrd::daemon

// The one place that decides what an Error looks like on the wire: the HTTP status for
// each error code (one table, kStatus in wire_error.cpp), and the JSON body
// {"error": {"code", "message", "field"}}.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "encode/result.hpp"

namespace hdrd::daemon {

// The status the table gives a code: an exact entry, else its family (the prefix up to and
// including the first '.'); nullopt when the table has neither. tests/daemon/transport_test
// collects every code the code base produces and fails on one without a status.
std::optional<unsigned> status_of(std::string_view code);

// HTTP status for an error (docs/api.md, "Errors"): status_of(code), 500 for a code the
// table does not know.
unsigned http_status(const Error& e);

// {"error":{"code":..,"message":..,"field":..}} (field omitted when empty), newline-terminated.
std::string error_body(const Error& e);

}  // namespace hdrd::daemon

// What every piece of a request must satisfy before a parser sees it, in one place for
// every entry point: JSON texts (bodies and multipart parts) bounded in size and depth
// and free of NUL bytes (job::parse_json_object_bounded, the request parser's own);
// query parameters well-formed UTF-8 without NUL or other control bytes, few and short; multipart uploads
// split into the EXR and its options. Pure: the fuzz targets link it without the HTTP server.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/http/server.hpp"
#include "encode/io/json_text.hpp"
#include "encode/result.hpp"
#include "job/request.hpp"

namespace hdrd::daemon {

inline constexpr std::size_t kMaxQueryParams = 64;
inline constexpr std::size_t kMaxQueryBytes = 4096;  // each key or value

using job::Limits;
using job::parse_json_object_bounded;  // request bodies, multipart 'request' parts, selftest
using job::request_json_bounds;

// Percent-decoded query parameters: at most kMaxQueryParams, each key and value at most
// kMaxQueryBytes, well-formed UTF-8, no NUL byte (%00). request.query naming the parameter.
Result<void> check_query(const std::vector<std::pair<std::string, std::string>>& query);

// The request target as the client sent it (before percent-decoding): no control byte
// (C0 or DEL), raw anywhere or percent-encoded in the path. libmicrohttpd decodes the path
// into a C string, so a %00 cut "DELETE /v1/jobs/ID%00/result" to "DELETE /v1/jobs/ID";
// other control bytes forge log lines. 400 request.target (RFC 3986 §2 allows none of them
// in a URI). Percent-encoded ones in the query are check_query's (400 request.query,
// naming the parameter).
Result<void> check_request_target(std::string_view raw_target);

// POST /v1/encode as multipart/form-data: exactly one 'image' part (the EXR) and at most
// one 'request' part (a JSON object of options); anything else is an error naming the part.
struct EncodeUpload {
  nlohmann::json options = nlohmann::json::object();
  std::string exr;
};
Result<EncodeUpload> split_encode_upload(std::vector<Part>& parts, const Limits& limits);

}  // namespace hdrd::daemon

// What an endpoint answers: status, content type, body (shared, so that coalesced
// requests send the same bytes without copies) and extra headers.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "daemon/wire_error.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon {

struct Reply {
  unsigned status = 200;
  std::string content_type = "application/json";
  std::shared_ptr<const std::string> body = std::make_shared<const std::string>();
  std::vector<std::pair<std::string, std::string>> headers;
  std::string error_code;  // set for error replies (access log, metrics)

  static Reply json(unsigned status, std::string text) {
    Reply r;
    r.status = status;
    r.body = std::make_shared<const std::string>(std::move(text));
    return r;
  }
  static Reply error(const Error& e) {
    Reply r = json(http_status(e), error_body(e));
    r.error_code = e.code;
    return r;
  }
};

}  // namespace hdrd::daemon

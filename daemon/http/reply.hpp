// What an endpoint answers: status, content type, body (shared, so that coalesced
// requests send the same bytes without copies) and extra headers.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "daemon/http/wire_error.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon {

// A file sent as the body (GET /v1/jobs/{id}/result): the HTTP layer streams it from the
// descriptor (MHD_create_response_from_fd), so a large video is never read into memory.
// Closed when the last copy of the reply is gone.
struct FileBody {
  int fd = -1;
  std::uint64_t size = 0;
  FileBody(int f, std::uint64_t n) : fd(f), size(n) {}
  ~FileBody() {
    if (fd >= 0) ::close(fd);
  }
  FileBody(const FileBody&) = delete;
  FileBody& operator=(const FileBody&) = delete;
};

struct Reply {
  unsigned status = 200;
  std::string content_type = "application/json";
  std::shared_ptr<const std::string> body = std::make_shared<const std::string>();
  std::vector<std::pair<std::string, std::string>> headers;
  std::string error_code;  // set for error replies (access log, metrics)
  std::shared_ptr<const FileBody> file;  // set: the body is this file (`body` stays empty)
  // Set: the body is these bytes (`body` stays empty): a frame's output moved out of its job
  // and handed to the HTTP layer as it is, never copied (coalesced requests share it).
  std::shared_ptr<const std::vector<std::uint8_t>> bytes;

  std::uint64_t body_size() const { return file ? file->size : bytes ? bytes->size() : body ? body->size() : 0; }

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

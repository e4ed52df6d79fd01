// A small blocking HTTP/1.1 client for the daemon's own API (hdrctl, tests, benchmarks):
// Unix socket or TCP, keep-alive, Content-Length and chunked responses. It only ever talks
// to hdrd; the server side is libmicrohttpd.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::daemon {

struct ClientResponse {
  int status = 0;
  std::string reason;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;

  const std::string* header(const std::string& lower_name) const {
    auto it = headers.find(lower_name);
    return it == headers.end() ? nullptr : &it->second;
  }
  // {"error": {...}} bodies as an Error (code "http.<status>" when the body is not one).
  Error error() const;
};

struct ClientOptions {
  std::string socket_path;      // Unix socket, or
  std::string tcp;              // host:port
  std::string token;            // bearer token for TCP
  double timeout_s = 300;       // whole request
  // Called about every 250 ms while waiting for the response (progress for long renders).
  std::function<void(double elapsed_s)> on_wait;
};

class Client {
 public:
  explicit Client(ClientOptions options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Sends one request (reusing the connection when the server kept it open). Errors:
  // client.connect, client.io, client.timeout, client.protocol.
  Result<ClientResponse> request(const std::string& method, const std::string& target, const std::string& body = {},
                                 const std::vector<std::pair<std::string, std::string>>& headers = {});
  // Like request() without a body, but a 2xx answer's body goes to `sink` piece by piece
  // as it arrives (the response's `body` stays empty), so a large result (a video) is never
  // held in memory. Other statuses keep their body (a JSON error) in the response. A sink
  // error ends the request with it; a connection lost after the first piece is not retried.
  using BodySink = std::function<Result<void>(std::string_view piece)>;
  Result<ClientResponse> download(const std::string& target, const BodySink& sink);
  void close();

 private:
  Result<void> connect();
  Result<void> send_all(std::string_view head, std::string_view body);
  Result<ClientResponse> exchange(const std::string& method, const std::string& target, const std::string& body,
                                  const std::vector<std::pair<std::string, std::string>>& headers, const BodySink* sink);
  Result<ClientResponse> read_response(bool head_request, const BodySink* sink, bool& delivered);
  Result<std::size_t> receive(std::string& into, std::size_t max, std::chrono::steady_clock::time_point deadline,
                              std::chrono::steady_clock::time_point start);
  Result<std::size_t> fill(std::chrono::steady_clock::time_point deadline, std::chrono::steady_clock::time_point start);

  ClientOptions options_;
  int fd_ = -1;
  std::string buffer_;  // bytes read but not consumed
};

// The default socket: $HDRD_SOCKET, else $XDG_RUNTIME_DIR/hdrd.sock, else /run/hdrd/hdrd.sock.
std::string default_client_socket();

// multipart/form-data (RFC 7578) body with a boundary that does not occur in the parts.
struct FormPart {
  std::string name, filename, content_type, data;
};
std::string multipart_body(const std::vector<FormPart>& parts, std::string* content_type);

}  // namespace hdrd::daemon

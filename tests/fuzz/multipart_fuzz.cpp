// Fuzz target: a multipart/form-data POST /v1/encode body through the daemon's real HTTP
// layer (daemon/http/server.cpp on libmicrohttpd, whose post processor splits the parts)
// and what the endpoint does with the parts: split_encode_upload (the bounded JSON of the
// 'request' part, issue 14's crash), the request parser, the canonical JSON. The server
// runs in this process on a Unix socket; each input is one request on a fresh connection.
//
// Input: the first line is the boundary (mapped onto RFC 2046's boundary characters, so
// that the request header itself is always valid), the rest the body. Invariants beyond
// "no crash": every request is answered, with 200 or a 4xx whose body is the JSON error,
// never a 5xx (the body is the client's fault or fine), within the time limit.
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "daemon/http/server.hpp"
#include "daemon/http/input_bounds.hpp"
#include "daemon/http/listener.hpp"
#include "job/request.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd;
using namespace hdrd::daemon;

// A broken invariant: says which and what the server answered, then aborts (the fuzzer
// keeps the input).
void check(bool ok, const char* what = "", const std::string& reply = {}) {
  if (ok) return;
  std::fprintf(stderr, "multipart_fuzz: %s; the reply was:\n%.2000s\n", what, reply.c_str());
  std::abort();
}

class UploadHandler final : public HttpHandler {
 public:
  std::variant<std::size_t, Reply> begin(const HttpRequest&) noexcept override { return std::size_t(1) << 20; }
  void handle(HttpRequest& request, std::shared_ptr<Responder> responder) noexcept override {
    try {
      if (!request.multipart) return responder->reply(Reply::error(make_error("request.media_type", "not multipart")));
      auto upload = split_encode_upload(request.parts, limits_);
      if (!upload) return responder->reply(Reply::error(upload.error()));
      job::ParseContext ctx;
      ctx.source = job::Source::encode;
      ctx.reach = job::Reach::daemon;
      auto parsed = job::parse_request_json(upload->options, ctx);
      if (!parsed) return responder->reply(Reply::error(parsed.error()));
      responder->reply(Reply::json(200, parsed->canonical().dump()));  // strict UTF-8
    } catch (const std::exception& e) {
      std::fprintf(stderr, "multipart_fuzz: exception escaped: %s\n", e.what());
      std::abort();
    }
  }
  void finished(const HttpRequest&, const Reply&, std::size_t) noexcept override {}

 private:
  Limits limits_;
};

struct InProcessServer {
  fs::path dir = fs::temp_directory_path() / ("hdrd-multipart-fuzz-" + std::to_string(::getpid()));
  fs::path socket = dir / "s.sock";
  UploadHandler handler;
  HttpServer server{handler, HttpServerOptions{}};
  InProcessServer() {
    spdlog::set_level(spdlog::level::off);  // the server logs every start; the fuzzer's output is enough
    fs::create_directories(dir);
    server.add_listener(listen_unix(socket, 0600, ""));
  }
  ~InProcessServer() {
    server.stop();
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

InProcessServer& server() {
  static InProcessServer s;
  return s;
}

std::string boundary_from(std::string_view raw) {
  static constexpr std::string_view kChars = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz'()+_,-./:=?";
  std::string b;
  for (unsigned char c : raw.substr(0, 70)) b += kChars[c % kChars.size()];
  return b.empty() ? "b" : b;
}

std::string exchange(const std::string& request) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", server().socket.c_str());
  check(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0);
  timeval tv{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  for (std::size_t done = 0; done < request.size();) {
    const ssize_t n = ::send(fd, request.data() + done, request.size() - done, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may answer early and close
    done += std::size_t(n);
  }
  std::string reply;
  char buf[8192];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    reply.append(buf, std::size_t(n));
  }
  ::close(fd);
  return reply;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t nl = input.find('\n');
  const std::string boundary = boundary_from(nl == std::string::npos ? std::string_view{} : std::string_view(input).substr(0, nl));
  const std::string body = nl == std::string::npos ? input : input.substr(nl + 1);
  const std::string request = "POST /v1/encode HTTP/1.1\r\nHost: fuzz\r\nContent-Type: multipart/form-data; boundary=\"" +
                              boundary + "\"\r\nContent-Length: " + std::to_string(body.size()) +
                              "\r\nConnection: close\r\n\r\n" + body;
  const std::string reply = exchange(request);
  check(reply.rfind("HTTP/1.1 ", 0) == 0, "no answer (dropped or timed out)", reply);
  const int status = std::atoi(reply.c_str() + 9);
  if (status != 200) {
    const auto at = reply.find("\r\n\r\n");
    check(at != std::string::npos, "no end of the headers", reply);
    const auto j = nlohmann::json::parse(reply.substr(at + 4), nullptr, false);
    check(j.is_object() && j.contains("error") && j["error"].contains("code"), "not the JSON error body", reply);
    // A 4xx for the client's fault; or 503 server.busy, the documented refusal when the
    // connection table is full (a starved fuzzer opens connections faster than the server
    // retires them): load, not a verdict on the input.
    const bool busy = status == 503 && j["error"].value("code", "") == "server.busy";
    check((status >= 400 && status < 500) || busy, "not a 4xx for a client's fault", reply);
  }
  return 0;
}

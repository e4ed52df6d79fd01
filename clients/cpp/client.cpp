#include "clients/cpp/client.hpp"

#include <netdb.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace hdrd::daemon {
namespace {

using Clock = std::chrono::steady_clock;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

}  // namespace

Error ClientResponse::error() const {
  auto j = nlohmann::json::parse(body, nullptr, false);
  if (j.is_object() && j.contains("error") && j["error"].is_object()) {
    const auto& e = j["error"];
    return make_error(e.value("code", "http." + std::to_string(status)), e.value("message", reason),
                      e.value("field", ""));
  }
  return make_error("http." + std::to_string(status), fmt::format("HTTP {} {}", status, reason));
}

std::string default_client_socket() {
  if (const char* s = std::getenv("HDRD_SOCKET"); s && *s) return s;
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) return std::string(x) + "/hdrd.sock";
  return "/run/hdrd/hdrd.sock";
}

Client::Client(ClientOptions options) : options_(std::move(options)) {}
Client::~Client() { close(); }

void Client::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  buffer_.clear();
}

Result<void> Client::connect() {
  if (!options_.tcp.empty()) {
    const auto colon = options_.tcp.rfind(':');
    if (colon == std::string::npos) return make_error("client.connect", "TCP address must be host:port");
    std::string host = options_.tcp.substr(0, colon);
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    addrinfo hints{};
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    if (::getaddrinfo(host.c_str(), options_.tcp.substr(colon + 1).c_str(), &hints, &res) != 0 || !res)
      return make_error("client.connect", "cannot resolve " + options_.tcp);
    fd_ = ::socket(res->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int rc = fd_ < 0 ? -1 : ::connect(fd_, res->ai_addr, res->ai_addrlen);
    ::freeaddrinfo(res);
    if (rc != 0) {
      const std::string why = std::strerror(errno);
      close();
      return make_error("client.connect", fmt::format("cannot connect to {}: {}", options_.tcp, why));
    }
    return {};
  }
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (options_.socket_path.size() >= sizeof addr.sun_path)
    return make_error("client.connect", "socket path too long: " + options_.socket_path);
  std::memcpy(addr.sun_path, options_.socket_path.c_str(), options_.socket_path.size() + 1);
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const std::string why = std::strerror(errno);
    close();
    return make_error("client.connect", fmt::format("cannot connect to {}: {} (is `hdrd serve` running?)",
                                                    options_.socket_path, why));
  }
  return {};
}

// The request head and its body go out with one sendmsg() each time, without first being
// joined into one string (a 4K upload would otherwise be copied once more before it leaves).
Result<void> Client::send_all(std::string_view head, std::string_view body) {
  const std::size_t total = head.size() + body.size();
  std::size_t off = 0;
  while (off < total) {
    iovec v[2];
    std::size_t n = 0;
    if (off < head.size()) {
      v[n++] = {const_cast<char*>(head.data() + off), head.size() - off};
      if (!body.empty()) v[n++] = {const_cast<char*>(body.data()), body.size()};
    } else {
      v[n++] = {const_cast<char*>(body.data() + (off - head.size())), total - off};
    }
    msghdr m{};
    m.msg_iov = v;
    m.msg_iovlen = n;
    const ssize_t sent = ::sendmsg(fd_, &m, MSG_NOSIGNAL);
    if (sent < 0 && errno == EINTR) continue;
    if (sent <= 0) return make_error("client.io", std::string("send failed: ") + std::strerror(errno));
    off += std::size_t(sent);
  }
  return {};
}

// Reads up to `max` more bytes onto the end of `into` (buffer_, or a body being received
// straight into its final string); 0 means the server closed the connection. It waits in
// poll() only when nothing is there yet.
Result<std::size_t> Client::receive(std::string& into, std::size_t max, Clock::time_point deadline,
                                    Clock::time_point start) {
  const std::size_t old = into.size();
  for (;;) {
    // Only what is there is made room for (resize() zero-fills what it adds).
    int avail = 0;
    if (::ioctl(fd_, FIONREAD, &avail) != 0) avail = 0;
    const std::size_t want = std::min<std::size_t>(max, avail > 0 ? std::size_t(avail) : std::size_t(64) * 1024);
    into.resize(old + want);
    const ssize_t n = ::recv(fd_, into.data() + old, want, MSG_DONTWAIT);
    into.resize(old + std::size_t(std::max<ssize_t>(n, 0)));
    if (n >= 0) return std::size_t(n);
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK)
      return make_error("client.io", std::string("receive failed: ") + std::strerror(errno));
    for (;;) {
      const auto now = Clock::now();
      if (now >= deadline) return make_error("client.timeout", "timed out waiting for the daemon");
      const int wait_ms = int(std::min<long long>(
          250, std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count() + 1));
      pollfd p{fd_, POLLIN, 0};
      const int rc = ::poll(&p, 1, wait_ms);
      if (rc < 0 && errno == EINTR) continue;
      if (rc == 0) {
        if (options_.on_wait) options_.on_wait(std::chrono::duration<double>(Clock::now() - start).count());
        continue;
      }
      break;
    }
  }
}

Result<std::size_t> Client::fill(Clock::time_point deadline, Clock::time_point start) {
  return receive(buffer_, 256 * 1024, deadline, start);
}

Result<ClientResponse> Client::read_response(bool head_request, const BodySink* sink, bool& delivered) {
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.timeout_s));
  for (;;) {  // skips 1xx interim responses
    std::size_t header_end;
    while ((header_end = buffer_.find("\r\n\r\n")) == std::string::npos) {
      if (buffer_.size() > 256 * 1024) return make_error("client.protocol", "response headers too large");
      auto n = fill(deadline, start);
      if (!n) return n.error();
      if (*n == 0) return make_error("client.io", "the daemon closed the connection before answering");
    }
    ClientResponse r;
    const std::string head = buffer_.substr(0, header_end);
    buffer_.erase(0, header_end + 4);
    std::size_t line_end = head.find("\r\n");
    const std::string status_line = head.substr(0, line_end);
    if (status_line.rfind("HTTP/1.", 0) != 0 || status_line.size() < 12)
      return make_error("client.protocol", "bad status line: " + status_line.substr(0, 80));
    r.status = std::atoi(status_line.c_str() + 9);
    r.reason = status_line.size() > 13 ? status_line.substr(13) : "";
    while (line_end != std::string::npos) {
      const std::size_t next = head.find("\r\n", line_end + 2);
      const std::string line = head.substr(line_end + 2, next == std::string::npos ? std::string::npos : next - line_end - 2);
      line_end = next;
      const auto colon = line.find(':');
      if (colon == std::string::npos) continue;
      const std::string name = lower(line.substr(0, colon));
      auto [it, fresh] = r.headers.emplace(name, trim(line.substr(colon + 1)));
      if (!fresh) it->second += ", " + trim(line.substr(colon + 1));
    }
    if (r.status >= 100 && r.status < 200) continue;
    // The first n bytes of buffer_ are body: to the sink (a 2xx download) or the response.
    const bool stream = sink && r.status >= 200 && r.status < 300;
    auto take = [&](std::size_t n) -> Result<void> {
      if (n == 0) return {};
      if (stream) {
        delivered = true;
        if (auto ok = (*sink)(std::string_view(buffer_.data(), n)); !ok) return ok.error();
      } else {
        r.body.append(buffer_, 0, n);
      }
      buffer_.erase(0, n);
      return {};
    };
    // `left` bytes of body, as they arrive.
    auto take_exactly = [&](std::size_t left, const char* closed) -> Result<void> {
      while (left > 0) {
        if (buffer_.empty()) {
          auto n = fill(deadline, start);
          if (!n) return n.error();
          if (*n == 0) return make_error("client.io", closed);
        }
        const std::size_t n = std::min(left, buffer_.size());
        if (auto ok = take(n); !ok) return ok.error();
        left -= n;
      }
      return {};
    };
    const bool chunked = r.header("transfer-encoding") && lower(*r.header("transfer-encoding")).find("chunked") != std::string::npos;
    const bool no_body = head_request || r.status == 204 || r.status == 304;
    if (no_body) {
    } else if (chunked) {
      for (;;) {
        std::size_t eol;
        while ((eol = buffer_.find("\r\n")) == std::string::npos) {
          auto n = fill(deadline, start);
          if (!n) return n.error();
          if (*n == 0) return make_error("client.io", "connection closed inside a chunked body");
        }
        const std::size_t size = std::strtoull(buffer_.c_str(), nullptr, 16);
        buffer_.erase(0, eol + 2);
        if (auto ok = take_exactly(size, "connection closed inside a chunk"); !ok) return ok.error();
        while (buffer_.size() < 2) {
          auto n = fill(deadline, start);
          if (!n) return n.error();
          if (*n == 0) return make_error("client.io", "connection closed inside a chunk");
        }
        buffer_.erase(0, 2);
        if (size == 0) break;  // (trailers are not used by hdrd)
      }
    } else if (const auto* cl = r.header("content-length")) {
      const std::size_t length = std::strtoull(cl->c_str(), nullptr, 10);
      if (stream) {
        if (auto ok = take_exactly(length, "connection closed before the whole body arrived"); !ok) return ok.error();
      } else {
        // Received straight into the body: one allocation of the announced length (up to
        // 256 MiB: a bogus length costs address space, not memory, and longer bodies grow)
        // and no copy through buffer_.
        try {
          r.body.reserve(std::min<std::size_t>(length, std::size_t(256) << 20));
        } catch (const std::bad_alloc&) {
        }
        const std::size_t first = std::min(length, buffer_.size());
        if (auto ok = take(first); !ok) return ok.error();
        for (std::size_t left = length - first; left > 0;) {
          auto n = receive(r.body, std::min<std::size_t>(left, std::size_t(4) << 20), deadline, start);
          if (!n) return n.error();
          if (*n == 0) return make_error("client.io", "connection closed before the whole body arrived");
          left -= *n;
        }
      }
    } else {
      for (;;) {
        if (auto ok = take(buffer_.size()); !ok) return ok.error();
        auto n = fill(deadline, start);
        if (!n) return n.error();
        if (*n == 0) break;
      }
      close();
    }
    if (const auto* c = r.header("connection"); c && lower(*c).find("close") != std::string::npos) close();
    return r;
  }
}

Result<ClientResponse> Client::request(const std::string& method, const std::string& target, const std::string& body,
                                       const std::vector<std::pair<std::string, std::string>>& headers) {
  return exchange(method, target, body, headers, nullptr);
}

Result<ClientResponse> Client::download(const std::string& target, const BodySink& sink) {
  return exchange("GET", target, {}, {}, &sink);
}

Result<ClientResponse> Client::exchange(const std::string& method, const std::string& target, const std::string& body,
                                        const std::vector<std::pair<std::string, std::string>>& headers,
                                        const BodySink* sink) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool reused = fd_ >= 0;
    if (!reused)
      if (auto c = connect(); !c) return c.error();
    std::string req = fmt::format("{} {} HTTP/1.1\r\nHost: localhost\r\n", method, target);
    if (!options_.token.empty()) req += "Authorization: Bearer " + options_.token + "\r\n";
    for (const auto& [k, v] : headers) req += k + ": " + v + "\r\n";
    if (!body.empty() || method == "POST" || method == "PUT") req += fmt::format("Content-Length: {}\r\n", body.size());
    req += "\r\n";
    auto sent = send_all(req, body);
    if (sent) {
      bool delivered = false;
      auto r = read_response(method == "HEAD", sink, delivered);
      if (r) return r;
      // A kept-alive connection the server had already closed: retry once on a new one,
      // unless part of the body already went to the sink.
      if (!reused || delivered || r.error().code != "client.io") {
        close();
        return r.error();
      }
    } else if (!reused) {
      return sent.error();
    }
    close();
  }
  return make_error("client.io", "the daemon closed the connection");
}

std::string multipart_body(const std::vector<FormPart>& parts, std::string* content_type) {
  std::mt19937_64 rng(std::random_device{}());
  std::string boundary;
  for (;;) {
    boundary = fmt::format("hdrd-{:016x}{:016x}", rng(), rng());
    bool clash = false;
    for (const auto& p : parts) clash = clash || p.data.find(boundary) != std::string::npos;
    if (!clash) break;
  }
  std::string out;
  for (const auto& p : parts) {
    out += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + p.name + "\"";
    if (!p.filename.empty()) out += "; filename=\"" + p.filename + "\"";
    out += "\r\n";
    if (!p.content_type.empty()) out += "Content-Type: " + p.content_type + "\r\n";
    out += "\r\n" + p.data + "\r\n";
  }
  out += "--" + boundary + "--\r\n";
  *content_type = "multipart/form-data; boundary=" + boundary;
  return out;
}

}  // namespace hdrd::daemon

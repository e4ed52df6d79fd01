// Issue 28's HTTP items on the real `hdrd serve`, with raw requests over the Unix socket:
// no complete request is dropped without an answer (many short connections under the
// default caps), the framing and target rules (RFC 9112 §6.3, RFC 3986 §2), and the log
// escaping of what clients send. The oracle is the HTTP contract: every request that was
// sent whole gets a complete reply (status line, Content-Length, body) before its
// connection closes.
#include <gtest/gtest.h>

#include <atomic>
#include <iostream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tests/daemon/daemon_harness.hpp"

namespace hdrd::testing {
namespace {

using nlohmann::json;

#define REQUIRE_DAEMON(d) \
  ASSERT_TRUE((d).ready()) << "hdrd serve did not come up; its log:\n" << (d).log()

struct Exchange {
  bool complete = false;  // a whole reply arrived
  int status = 0;
  std::string head, body;
};

// Sends `request` on a fresh connection, reads one reply by its Content-Length, closes.
Exchange http_exchange(const std::filesystem::path& socket, const std::string& request,
                  std::chrono::seconds limit = std::chrono::seconds(30)) {
  Exchange x;
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", socket.c_str());
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return x;
  if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) != ssize_t(request.size())) return x;
  timeval tv{0, 200000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string text;
  std::size_t want = std::string::npos;  // head + body, once the head is in
  const auto end = std::chrono::steady_clock::now() + limit;
  char buf[8192];
  while (std::chrono::steady_clock::now() < end && text.size() < want) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      break;
    }
    text.append(buf, std::size_t(n));
    if (want == std::string::npos)
      if (const auto head_end = text.find("\r\n\r\n"); head_end != std::string::npos) {
        x.head = text.substr(0, head_end + 2);
        std::size_t length = 0;
        if (const auto p = x.head.find("Content-Length: "); p != std::string::npos)
          length = std::stoul(x.head.substr(p + 16));
        want = head_end + 4 + length;
      }
  }
  if (want == std::string::npos || text.size() < want || text.rfind("HTTP/1.1 ", 0) != 0) return x;
  x.status = std::atoi(text.c_str() + 9);
  x.body = text.substr(x.head.size() + 2, want - x.head.size() - 2);
  x.complete = true;
  return x;
}

std::string error_code(const std::string& body) {
  auto j = json::parse(body, nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "(not a JSON error: " + body.substr(0, 80) + ")";
}

struct Tally {
  std::atomic<int> ok{0}, busy{0}, other{0}, dropped{0};
};

// `clients` threads, each sending `per_client` GET /v1/status, one connection at a time:
// connect, send, read the reply, close (as curl or Python's http.client do).
void run_clients(const DaemonProcess& d, int clients, int per_client, Tally& t) {
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i)
    threads.emplace_back([&] {
      for (int k = 0; k < per_client; ++k) {
        const Exchange x = http_exchange(d.socket(), "GET /v1/status HTTP/1.1\r\nHost: x\r\n\r\n");
        if (!x.complete) ++t.dropped;
        else if (x.status == 200) ++t.ok;
        else if (x.status == 503 && error_code(x.body) == "server.busy" &&
                 x.head.find("Retry-After: 1") != std::string::npos)
          ++t.busy;
        else ++t.other;
      }
    });
  for (auto& th : threads) th.join();
}

// Issue 28 item 4: 40 clients below max_connections_per_peer = 64 lost 12-27 of 2400
// requests (connections closed without a reply): the table still counted connections
// their clients had closed, and closed, for room, new ones whose requests MHD had not read.
TEST(DaemonHttpEdges, FortyClientsWithAConnectionEachLoseNoRequest) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  Tally t;
  run_clients(d, 40, 60, t);
  std::cout << fmt::format("40 clients x 60: {} ok, {} busy, {} other, {} dropped\n", t.ok.load(), t.busy.load(),
                           t.other.load(), t.dropped.load());
  EXPECT_EQ(t.dropped.load(), 0) << "connections closed without a reply";
  EXPECT_EQ(t.ok.load(), 2400) << "below the caps, every request is served";
  EXPECT_TRUE(d.alive());
}

// 100 clients of one uid are over the per-peer cap: some connections are refused, and each
// refusal is an answer (503 server.busy, Retry-After), never a dropped request.
TEST(DaemonHttpEdges, AHundredClientsOverThePeerCapAreAllAnswered) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  Tally t;
  run_clients(d, 100, 24, t);
  std::cout << fmt::format("100 clients x 24: {} ok, {} busy, {} other, {} dropped\n", t.ok.load(), t.busy.load(),
                           t.other.load(), t.dropped.load());
  EXPECT_EQ(t.dropped.load(), 0) << "connections closed without a reply";
  EXPECT_EQ(t.other.load(), 0);
  EXPECT_EQ(t.ok.load() + t.busy.load(), 2400);
  EXPECT_GT(t.ok.load(), 1200) << "most requests are served";
  EXPECT_TRUE(d.alive());
}

// Item 5: two Content-Length fields were accepted (the first one framed the body).
TEST(DaemonHttpEdges, MoreThanOneContentLengthIsA400AndTheConnectionCloses) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  for (const char* lengths : {"Content-Length: 2\r\nContent-Length: 40\r\n", "Content-Length: 2\r\nContent-Length: 2\r\n",
                              "Content-Length: 2, 2\r\n"}) {
    RawConnection c(d.socket());
    ASSERT_TRUE(c.send(fmt::format("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n{}\r\n{{}}"
                                   "GET /v1/status HTTP/1.1\r\nHost: x\r\n\r\n", lengths)));
    auto [text, closed] = c.read_until_closed(std::chrono::seconds(10));
    EXPECT_EQ(text.rfind("HTTP/1.1 400", 0), 0u) << lengths << text.substr(0, 300);
    // A list in one field never reaches hdrd: libmicrohttpd answers it 400 itself (its HTML).
    if (std::string(lengths).find(',') == std::string::npos) {
      EXPECT_EQ(error_code(text.substr(text.find("\r\n\r\n") + 4)), "request.content_length") << lengths;
    }
    EXPECT_TRUE(closed) << "the connection closes after a framing error";
    EXPECT_EQ(text.find("HTTP/1.1 200"), std::string::npos) << "nothing after the bad request is served";
  }
}

// Item 5: a NUL in the target cut the path (DELETE /v1/jobs/ID%00/result deleted the job);
// every control byte, raw or percent-encoded, is a 400 before routing.
TEST(DaemonHttpEdges, AControlByteInTheTargetIsA400NeverATruncation) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const std::string targets[] = {
      "/v1/status%00x",        "/v1/status%00",       "/v1/jobs/j1%00/result", "/v1/status%0a",
      "/v1/status%0D%0Ax",     "/v1/status%1b[31m",   "/v1/status%7f",         "/v1/status?x=\x01",
      std::string("/v1/status\0x", 12), "/v1/status\x1b[2J", "/v1/status\x7f",
  };
  for (const std::string& target : targets) {
    for (const char* method : {"GET", "DELETE"}) {
      const Exchange x = http_exchange(d.socket(), fmt::format("{} {} HTTP/1.1\r\nHost: x\r\n\r\n", method, target));
      ASSERT_TRUE(x.complete) << method << " " << target;
      EXPECT_EQ(x.status, 400) << method << " " << target << ": " << x.body;
      EXPECT_EQ(error_code(x.body), "request.target") << method << " " << target;
    }
  }
  // In the query, percent-encoded: request.query, naming the parameter.
  for (const char* target : {"/v1/status?x=%01", "/v1/status?mode=hdr10%0a", "/v1/status?a%1b=1"}) {
    const Exchange x = http_exchange(d.socket(), fmt::format("GET {} HTTP/1.1\r\nHost: x\r\n\r\n", target));
    EXPECT_EQ(x.status, 400) << target;
    EXPECT_EQ(error_code(x.body), "request.query") << target;
  }
  // Plain targets, percent-encoded printable bytes and queries still work.
  for (const char* target : {"/v1/status", "/v1/%73tatus", "/v1/status?x=%41"})
    EXPECT_EQ(http_exchange(d.socket(), fmt::format("GET {} HTTP/1.1\r\nHost: x\r\n\r\n", target)).status, 200) << target;
}

// Item 6: %0a, %0d, %1b and raw ESC in the path reached the access log raw (a forged line,
// terminal escapes). Every log line is escaped; the log holds no control byte but its
// line ends.
TEST(DaemonHttpEdges, WhatClientsSendReachesTheLogEscaped) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const std::string forged = "2026-01-01T00:00:00.000 info #999 forged";
  for (const std::string& target : {"/v1/x%0a" + forged + "%1b[31m", "/v1/x%0d%0a" + forged, std::string("/v1/x\x1b[2J")}) {
    std::string t = target;
    for (std::size_t p; (p = t.find(' ')) != std::string::npos;) t.replace(p, 1, "%20");
    EXPECT_TRUE(http_exchange(d.socket(), fmt::format("GET {} HTTP/1.1\r\nHost: x\r\n\r\n", t)).complete) << t;
  }
  EXPECT_TRUE(http_exchange(d.socket(), "GET /v1/status HTTP/1.1\r\nHost: x\r\nX-End: 1\r\n\r\n").complete);
  const std::string log = d.log();
  for (std::size_t i = 0; i < log.size(); ++i) {
    const unsigned char b = static_cast<unsigned char>(log[i]);
    ASSERT_FALSE((b < 0x20 && b != '\n') || b == 0x7f) << fmt::format("control byte 0x{:02x} at {}: ", b, i)
                                                        << log.substr(i > 80 ? i - 80 : 0, 160);
  }
  EXPECT_EQ(log.find("\n" + forged), std::string::npos) << "a forged line starts a line:\n" << log;
  EXPECT_NE(log.find("/v1/x\\n2026-01-01"), std::string::npos) << "the request is logged, escaped:\n" << log;
}

}  // namespace
}  // namespace hdrd::testing

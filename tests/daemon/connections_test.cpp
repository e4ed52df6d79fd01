// The connection table (daemon/http/connections.hpp) without MHD: socket pairs stand in for
// connections, and time is passed in, so every deadline here is forced, not waited for.
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "daemon/http/connections.hpp"

namespace hdrd::daemon {
namespace {

using Clock = ConnectionTable::Clock;
using namespace std::chrono_literals;

// One socket pair: the table holds `server`, the test reads what the "client" sees.
struct Pair {
  int server = -1, client = -1;
  Pair() {
    int fds[2];
    EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds), 0);
    server = fds[0];
    client = fds[1];
  }
  ~Pair() {
    ::close(server);
    ::close(client);
  }
  const void* key() const { return this; }
  // What the client has received, and whether the server side was shut down (EOF).
  std::pair<std::string, bool> received() const {
    std::string out;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(client, buf, sizeof buf, MSG_DONTWAIT);
      if (n == 0) return {out, true};
      if (n < 0) return {out, false};
      out.append(buf, std::size_t(n));
    }
  }
};

ConnectionLimits limits(int total, int per_peer) {
  ConnectionLimits l;
  l.max_connections = total;
  l.max_connections_per_peer = per_peer;
  l.header_timeout_s = 10;
  l.body_grace_s = 5;
  l.min_body_bytes_per_s = 1000;
  return l;
}

std::string error_code_of(const std::string& http) {
  const auto body = http.find("\r\n\r\n");
  if (body == std::string::npos) return {};
  return nlohmann::json::parse(http.substr(body + 4))["error"]["code"];
}

TEST(Connections, ANewConnectionOverThePeerCapClosesThatPeersOldestIdleOne) {
  ConnectionTable t(limits(10, 2));
  Pair a, b, c, other;
  const auto t0 = Clock::now();
  EXPECT_TRUE(t.opened(a.key(), a.server, "uid:1", t0));
  EXPECT_TRUE(t.opened(other.key(), other.server, "uid:2", t0));
  EXPECT_TRUE(t.opened(b.key(), b.server, "uid:1", t0 + 1s));
  EXPECT_TRUE(t.opened(c.key(), c.server, "uid:1", t0 + 2s));
  auto [text, closed] = a.received();
  EXPECT_TRUE(closed) << "the oldest idle connection of uid:1 made room";
  EXPECT_EQ(error_code_of(text), "server.busy") << "told why, in case its client was just writing a request";
  EXPECT_FALSE(b.received().second);
  EXPECT_FALSE(other.received().second) << "another peer's connection is not touched";
  EXPECT_EQ(t.stats().evicted, 1u);
  EXPECT_EQ(t.stats().open, 3);
  t.closed(a.key());  // MHD reports it closed
  EXPECT_EQ(t.stats().open, 3);
}

TEST(Connections, RequestsInProgressAreNeverClosedForRoom) {
  ConnectionTable t(limits(2, 2));
  Pair a, b, c;
  const auto t0 = Clock::now();
  t.opened(a.key(), a.server, "uid:1", t0);
  t.opened(b.key(), b.server, "uid:1", t0);
  t.header_complete(a.key(), t0);
  t.busy(a.key());
  t.request_line(b.key());
  t.header_complete(b.key(), t0);
  t.busy(b.key());
  EXPECT_FALSE(t.opened(c.key(), c.server, "uid:1", t0)) << "all busy: the new one is refused";
  EXPECT_TRUE(t.refused(c.key()));
  EXPECT_FALSE(a.received().second);
  EXPECT_FALSE(b.received().second);
  EXPECT_EQ(t.stats().refused, 1u);
  // Once a reply went out, that connection waits for a header again and may make room:
  // a kept-alive connection, closed silently (its client retries on a new one).
  t.idle(a.key(), t0 + 1s);
  Pair d;
  EXPECT_TRUE(t.opened(d.key(), d.server, "uid:1", t0 + 2s));
  EXPECT_EQ(a.received(), std::make_pair(std::string(), true));
}

TEST(Connections, ATotalCapClosesTheOldestIdleConnectionOfAnyPeer) {
  ConnectionTable t(limits(2, 2));
  Pair a, b, c;
  const auto t0 = Clock::now();
  t.opened(a.key(), a.server, "uid:1", t0);
  t.opened(b.key(), b.server, "uid:2", t0 + 1s);
  t.request_line(a.key());  // a had started a request: it is told why it is closed
  EXPECT_TRUE(t.opened(c.key(), c.server, "uid:3", t0 + 2s));
  auto [text, closed] = a.received();
  EXPECT_TRUE(closed);
  EXPECT_NE(text.find("HTTP/1.1 503"), std::string::npos) << text;
  EXPECT_EQ(error_code_of(text), "server.busy");
}

TEST(Connections, HeaderDeadlineClosesTricklingAndIdleConnections) {
  ConnectionTable t(limits(10, 10));
  Pair trickle, idle, fast;
  const auto t0 = Clock::now();
  t.opened(trickle.key(), trickle.server, "uid:1", t0);
  t.opened(idle.key(), idle.server, "uid:1", t0);
  t.opened(fast.key(), fast.server, "uid:1", t0);
  t.request_line(trickle.key());
  t.header_complete(fast.key(), t0 + 1s);
  t.busy(fast.key());
  t.enforce(t0 + 9s);
  EXPECT_FALSE(trickle.received().second) << "within the deadline";
  t.enforce(t0 + 11s);
  auto [text, closed] = trickle.received();
  EXPECT_TRUE(closed);
  EXPECT_NE(text.find("HTTP/1.1 408"), std::string::npos) << text;
  EXPECT_EQ(error_code_of(text), "request.header_timeout");
  auto idle_seen = idle.received();
  EXPECT_TRUE(idle_seen.second);
  EXPECT_EQ(idle_seen.first, "") << "an idle keep-alive connection is closed silently";
  EXPECT_FALSE(fast.received().second) << "a request being handled has no header deadline";
  EXPECT_EQ(t.stats().header_timeouts, 2u);
  // The deadline restarts with each reply.
  t.idle(fast.key(), t0 + 20s);
  t.enforce(t0 + 29s);
  EXPECT_FALSE(fast.received().second);
  t.enforce(t0 + 31s);
  EXPECT_TRUE(fast.received().second);
}

TEST(Connections, BodyBelowTheMinimumRateIsClosedAfterTheGrace) {
  ConnectionTable t(limits(10, 10));
  Pair slow, steady;
  const auto t0 = Clock::now();
  for (Pair* p : {&slow, &steady}) {
    t.opened(p->key(), p->server, "uid:1", t0);
    t.request_line(p->key());
    t.header_complete(p->key(), t0);
  }
  t.body_bytes(slow.key(), 10);
  t.body_bytes(steady.key(), 6000);  // 1000 B/s owed after the 5 s grace: 5000 by t0 + 10 s
  t.enforce(t0 + 5s);
  EXPECT_FALSE(slow.received().second) << "within the grace period";
  t.enforce(t0 + 10s);
  auto [text, closed] = slow.received();
  EXPECT_TRUE(closed);
  EXPECT_EQ(error_code_of(text), "request.body_timeout");
  EXPECT_FALSE(steady.received().second);
  EXPECT_EQ(t.stats().body_timeouts, 1u);
}

TEST(Connections, RefusedConnectionsGetAShortDeadlineAndDoNotCount) {
  ConnectionTable t(limits(1, 1));
  Pair a, b;
  const auto t0 = Clock::now();
  t.opened(a.key(), a.server, "uid:1", t0);
  t.header_complete(a.key(), t0);
  t.busy(a.key());
  EXPECT_FALSE(t.opened(b.key(), b.server, "uid:1", t0));
  EXPECT_EQ(t.stats().open, 1);
  t.enforce(t0 + 3s);
  EXPECT_TRUE(b.received().second) << "a refused connection that sends nothing is closed after 2 s";
  t.closed(b.key());
  t.closed(a.key());
  EXPECT_EQ(t.stats().open, 0);
}

bool send_request(int fd) {
  const std::string r = "GET /v1/status HTTP/1.1\r\nHost: x\r\n\r\n";
  return ::send(fd, r.data(), r.size(), MSG_NOSIGNAL) == ssize_t(r.size());
}

// Issue 28 item 4. A client that closed its connection stops counting as soon as room is
// needed, without waiting for MHD to report the close; the connection beside it, whose
// request MHD has not read yet, is not closed to make that room.
TEST(Connections, AConnectionItsClientClosedStopsCountingAtOnce) {
  ConnectionTable t(limits(10, 2));
  Pair gone, waiting, fresh;
  const auto t0 = Clock::now();
  t.opened(gone.key(), gone.server, "uid:1", t0);
  t.header_complete(gone.key(), t0);
  t.busy(gone.key());  // its reply went out; MHD has not got round to the close yet
  ::close(gone.client);
  gone.client = -1;
  t.opened(waiting.key(), waiting.server, "uid:1", t0 + 2s);
  ASSERT_TRUE(send_request(waiting.client));
  EXPECT_TRUE(t.opened(fresh.key(), fresh.server, "uid:1", t0 + 4s));
  EXPECT_FALSE(waiting.received().second) << "a connection carrying a request is not closed for room";
  EXPECT_EQ(t.stats().hung_up, 1u);
  EXPECT_EQ(t.stats().evicted, 0u);
  EXPECT_EQ(t.stats().open, 2);
}

TEST(Connections, AConnectionWithAnUnreadRequestIsNeverClosedForRoom) {
  ConnectionTable t(limits(10, 1));
  Pair a, b;
  const auto t0 = Clock::now();
  t.opened(a.key(), a.server, "uid:1", t0);
  ASSERT_TRUE(send_request(a.client));  // MHD is behind
  EXPECT_FALSE(t.opened(b.key(), b.server, "uid:1", t0 + 5s)) << "refused (503), not made room for";
  EXPECT_FALSE(a.received().second);
  EXPECT_EQ(t.stats().refused, 1u);
  EXPECT_EQ(t.stats().evicted, 0u);
}

// A client writes its first request right after connect(): closed for room just then, the
// connection can still take the request, and the client reads a 503.
TEST(Connections, AConnectionClosedForRoomIsAnswered503AndCanStillBeWrittenTo) {
  ConnectionTable t(limits(10, 1));
  Pair a, b;
  const auto t0 = Clock::now();
  t.opened(a.key(), a.server, "uid:1", t0);
  EXPECT_TRUE(t.opened(b.key(), b.server, "uid:1", t0));
  EXPECT_TRUE(t.closed_by_us(a.key()));
  EXPECT_TRUE(send_request(a.client)) << "the request still goes out (no EPIPE)";
  auto [text, closed] = a.received();
  EXPECT_TRUE(closed);
  EXPECT_NE(text.find("HTTP/1.1 503"), std::string::npos) << text;
  EXPECT_NE(text.find("Retry-After: 1"), std::string::npos) << text;
  EXPECT_EQ(error_code_of(text), "server.busy");
  // The read side closes too, a little later.
  t.enforce(t0 + 3s);
  EXPECT_FALSE(send_request(a.client)) << "shut for reading: a later write fails";
}

// The header deadline is the client's: when its request sits unread in the socket, the
// server is behind, and the request is answered rather than closed as late.
TEST(Connections, TheHeaderDeadlineSparesARequestTheServerHasNotRead) {
  ConnectionTable t(limits(10, 10));
  Pair sent, silent;
  const auto t0 = Clock::now();
  t.opened(sent.key(), sent.server, "uid:1", t0);
  t.opened(silent.key(), silent.server, "uid:1", t0);
  ASSERT_TRUE(send_request(sent.client));
  t.enforce(t0 + 11s);
  EXPECT_FALSE(sent.received().second);
  EXPECT_TRUE(silent.received().second);
  EXPECT_EQ(t.stats().header_timeouts, 1u);
}

}  // namespace
}  // namespace hdrd::daemon

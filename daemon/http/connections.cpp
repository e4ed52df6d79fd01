#include "daemon/http/connections.hpp"

#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>

#include <algorithm>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/http/wire_error.hpp"

namespace hdrd::daemon {
namespace {

// A connection refused for room gets this long to send the request its 503 answers.
constexpr double kRefusedHeaderTimeoutS = 2.0;

// A connection closed for room is answered 503 and half-closed (shutdown(SHUT_WR)): a
// client that writes its request just then can still send it, and reads the 503 instead of
// a broken pipe. The read side is shut this long after, if the client has not hung up.
constexpr double kClosedForRoomReadS = 2.0;

double seconds(ConnectionTable::Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Bytes the client sent that nobody has read yet.
bool has_unread_bytes(int fd) {
  int n = 0;
  return ::ioctl(fd, FIONREAD, &n) == 0 && n > 0;
}

}  // namespace

void send_raw_error(int fd, const Error& error, int retry_after_s) {
  const unsigned status = http_status(error);
  const std::string body = error_body(error);
  const char* reason = status == 408 ? "Request Timeout" : status == 503 ? "Service Unavailable" : "Error";
  const std::string retry = retry_after_s > 0 ? fmt::format("Retry-After: {}\r\n", retry_after_s) : std::string();
  const std::string reply = fmt::format(
      "HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n{}Connection: close\r\n\r\n{}",
      status, reason, body.size(), retry, body);
  (void)::send(fd, reply.data(), reply.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
}

bool ConnectionTable::opened(Key c, int fd, std::string peer, Clock::time_point now) {
  std::lock_guard lock(mu_);
  const bool ok = make_room(peer, c, now) && make_room({}, c, now);
  Entry e;
  e.fd = fd;
  e.peer = peer;
  e.since = now;
  e.refused = !ok;
  if (ok) {
    ++per_peer_[peer];
    ++open_;
  } else {
    ++stats_.refused;
  }
  entries_[c] = std::move(e);
  return ok;
}

int ConnectionTable::counted(const std::string& peer) const {
  if (peer.empty()) return open_;
  const auto it = per_peer_.find(peer);
  return it == per_peer_.end() ? 0 : it->second;
}

bool ConnectionTable::make_room(const std::string& peer, Key except, Clock::time_point now) {
  const int cap = peer.empty() ? limits_.max_connections : limits_.max_connections_per_peer;
  if (counted(peer) < cap) return true;
  close_hung_up(peer, except);
  if (counted(peer) < cap) return true;
  if (Entry* old = oldest_evictable(peer, except)) {
    close_entry(*old, Notice::evicted, now);
    ++stats_.evicted;
    return true;
  }
  return false;
}

void ConnectionTable::close_hung_up(const std::string& peer, Key except) {
  std::vector<Entry*> candidates;
  std::vector<pollfd> fds;
  for (auto& [key, e] : entries_) {
    if (key == except || e.closing || e.refused || e.fd < 0) continue;
    if (!peer.empty() && e.peer != peer) continue;
    candidates.push_back(&e);
    fds.push_back({e.fd, POLLRDHUP, 0});
  }
  if (fds.empty() || ::poll(fds.data(), fds.size(), 0) <= 0) return;
  for (std::size_t i = 0; i < fds.size(); ++i) {
    Entry& e = *candidates[i];
    const short ev = fds[i].revents;
    // POLLHUP: both directions are gone. POLLRDHUP alone is a half-close: the client may
    // still wait for the answer to a request it sent, so only a connection with no
    // request (none in progress, none unread) is given up.
    const bool gone = (ev & (POLLHUP | POLLERR | POLLNVAL)) ||
                      ((ev & POLLRDHUP) && e.phase == Phase::header && !e.started && !has_unread_bytes(e.fd));
    if (gone) {
      close_entry(e, Notice::none, {});
      ++stats_.hung_up;
    }
  }
}

ConnectionTable::Entry* ConnectionTable::oldest_evictable(const std::string& peer, Key except) {
  Entry* best = nullptr;
  for (auto& [key, e] : entries_) {
    if (key == except || e.closing || e.refused || e.phase != Phase::header) continue;
    if (!peer.empty() && e.peer != peer) continue;
    if (has_unread_bytes(e.fd)) continue;  // its request has arrived: MHD will read it
    if (!best || e.since < best->since) best = &e;
  }
  return best;
}

void ConnectionTable::closed(Key c) {
  std::lock_guard lock(mu_);
  auto it = entries_.find(c);
  if (it == entries_.end()) return;
  Entry& e = it->second;
  if (!e.closing && !e.refused) {
    --open_;
    if (--per_peer_[e.peer] <= 0) per_peer_.erase(e.peer);
  }
  entries_.erase(it);
}

void ConnectionTable::request_line(Key c) {
  std::lock_guard lock(mu_);
  if (auto it = entries_.find(c); it != entries_.end()) it->second.started = true;
}

void ConnectionTable::header_complete(Key c, Clock::time_point now) {
  std::lock_guard lock(mu_);
  if (auto it = entries_.find(c); it != entries_.end()) {
    it->second.phase = Phase::body;
    it->second.since = now;
    it->second.body_received = 0;
  }
}

void ConnectionTable::body_bytes(Key c, std::size_t n) {
  std::lock_guard lock(mu_);
  if (auto it = entries_.find(c); it != entries_.end()) it->second.body_received += n;
}

void ConnectionTable::busy(Key c) {
  std::lock_guard lock(mu_);
  if (auto it = entries_.find(c); it != entries_.end()) it->second.phase = Phase::busy;
}

void ConnectionTable::idle(Key c, Clock::time_point now) {
  std::lock_guard lock(mu_);
  if (auto it = entries_.find(c); it != entries_.end()) {
    it->second.phase = Phase::header;
    it->second.since = now;
    it->second.started = false;
    it->second.served = true;
  }
}

bool ConnectionTable::closed_by_us(Key c) const {
  std::lock_guard lock(mu_);
  auto it = entries_.find(c);
  return it != entries_.end() && it->second.closing;
}

bool ConnectionTable::refused(Key c) const {
  std::lock_guard lock(mu_);
  auto it = entries_.find(c);
  return it != entries_.end() && it->second.refused;
}

// Under mu_. The connection stays in the table until MHD reports it closed, but no longer
// counts against the caps.
void ConnectionTable::close_entry(Entry& e, Notice notice, Clock::time_point now) {
  if (e.closing) return;
  std::optional<Error> err;
  switch (notice) {
    case Notice::none: break;
    case Notice::evicted:
      // A kept-alive connection after a reply is closed silently: clients expect that and
      // retry on a new one (RFC 9112 §9.3.1; daemon::Client and hdrd_client.py do), where
      // a 503 read as the answer to their next request would not be retried. Any other is
      // told why: its client may be writing its first request right now.
      if (e.served && !e.started) break;
      err = make_error("server.busy", fmt::format("the connection was closed to make room for newer ones (at most {} "
                                                  "connections, {} per client); retry", limits_.max_connections,
                                                  limits_.max_connections_per_peer));
      break;
    case Notice::header_timeout:
      if (e.started)
        err = make_error("request.header_timeout", fmt::format("the request header did not arrive within {} s",
                                                               limits_.header_timeout_s));
      break;
    case Notice::body_timeout:
      err = make_error("request.body_timeout", fmt::format("the request body arrived slower than {} bytes/s",
                                                           limits_.min_body_bytes_per_s));
      break;
  }
  if (err) send_raw_error(e.fd, *err, notice == Notice::evicted ? 1 : 0);
  if (notice == Notice::evicted && err) {
    ::shutdown(e.fd, SHUT_WR);
    e.half_closed = true;
    e.since = now;
  } else {
    ::shutdown(e.fd, SHUT_RDWR);
  }
  e.closing = true;
  if (!e.refused) {
    --open_;
    if (--per_peer_[e.peer] <= 0) per_peer_.erase(e.peer);
  }
}

void ConnectionTable::enforce(Clock::time_point now) {
  std::lock_guard lock(mu_);
  for (auto& [key, e] : entries_) {
    if (e.closing) {
      if (e.half_closed && seconds(now - e.since) > kClosedForRoomReadS) {
        ::shutdown(e.fd, SHUT_RDWR);
        e.half_closed = false;
      }
      continue;
    }
    const double elapsed = seconds(now - e.since);
    if (e.phase == Phase::header) {
      const double limit = e.refused ? std::min(limits_.header_timeout_s, kRefusedHeaderTimeoutS) : limits_.header_timeout_s;
      // Unread bytes in the socket: the client has sent, the server is behind (a loaded
      // machine); the request is read and answered, not closed as late.
      if (elapsed > limit && !has_unread_bytes(e.fd)) {
        ++stats_.header_timeouts;
        close_entry(e, Notice::header_timeout, now);
      }
    } else if (e.phase == Phase::body && elapsed > limits_.body_grace_s) {
      // Apache mod_reqtimeout's MinRate: after the grace period, the body must keep up.
      const double owed = double(limits_.min_body_bytes_per_s) * (elapsed - limits_.body_grace_s);
      if (double(e.body_received) < owed) {
        ++stats_.body_timeouts;
        close_entry(e, Notice::body_timeout, now);
      }
    }
  }
}

void ConnectionTable::set_limits(const ConnectionLimits& limits) {
  std::lock_guard lock(mu_);
  limits_ = limits;
}

ConnectionStats ConnectionTable::stats() const {
  std::lock_guard lock(mu_);
  ConnectionStats s = stats_;
  s.open = open_;
  return s;
}

}  // namespace hdrd::daemon

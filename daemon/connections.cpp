#include "daemon/connections.hpp"

#include <sys/socket.h>

#include <algorithm>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/wire_error.hpp"

namespace hdrd::daemon {
namespace {

// A connection refused for room gets this long to send the request its 503 answers.
constexpr double kRefusedHeaderTimeoutS = 2.0;

double seconds(ConnectionTable::Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

void send_raw_error(int fd, const Error& error) {
  const unsigned status = http_status(error);
  const std::string body = error_body(error);
  const char* reason = status == 408 ? "Request Timeout" : status == 503 ? "Service Unavailable" : "Error";
  const std::string reply = fmt::format(
      "HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{}", status,
      reason, body.size(), body);
  (void)::send(fd, reply.data(), reply.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
}

bool ConnectionTable::opened(Key c, int fd, std::string peer, Clock::time_point now) {
  std::lock_guard lock(mu_);
  bool ok = true;
  if (per_peer_[peer] >= limits_.max_connections_per_peer) {
    if (Entry* old = oldest_waiting(peer, c)) close_entry(*old, Notice::evicted), ++stats_.evicted;
    else ok = false;
  }
  if (ok && open_ >= limits_.max_connections) {
    if (Entry* old = oldest_waiting({}, c)) close_entry(*old, Notice::evicted), ++stats_.evicted;
    else ok = false;
  }
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
    if (per_peer_[peer] == 0) per_peer_.erase(peer);
  }
  entries_[c] = std::move(e);
  return ok;
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
  }
}

bool ConnectionTable::refused(Key c) const {
  std::lock_guard lock(mu_);
  auto it = entries_.find(c);
  return it != entries_.end() && it->second.refused;
}

ConnectionTable::Entry* ConnectionTable::oldest_waiting(const std::string& peer, Key except) {
  Entry* best = nullptr;
  for (auto& [key, e] : entries_) {
    if (key == except || e.closing || e.refused || e.phase != Phase::header) continue;
    if (!peer.empty() && e.peer != peer) continue;
    if (!best || e.since < best->since) best = &e;
  }
  return best;
}

// Under mu_. The connection stays in the table until MHD reports it closed, but no longer
// counts against the caps.
void ConnectionTable::close_entry(Entry& e, Notice notice) {
  if (e.closing) return;
  std::optional<Error> err;
  switch (notice) {
    case Notice::none: break;
    case Notice::evicted:
      // Only a connection that had started a request is told; an idle one is simply closed.
      if (e.started && !e.refused)
        err = make_error("server.busy", fmt::format("the connection was closed to make room for newer ones (at "
                                                    "most {} connections)", limits_.max_connections));
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
  if (err) send_raw_error(e.fd, *err);
  ::shutdown(e.fd, SHUT_RDWR);
  e.closing = true;
  if (!e.refused) {
    --open_;
    if (--per_peer_[e.peer] <= 0) per_peer_.erase(e.peer);
  }
}

void ConnectionTable::enforce(Clock::time_point now) {
  std::lock_guard lock(mu_);
  for (auto& [key, e] : entries_) {
    if (e.closing) continue;
    const double elapsed = seconds(now - e.since);
    if (e.phase == Phase::header) {
      const double limit = e.refused ? std::min(limits_.header_timeout_s, kRefusedHeaderTimeoutS) : limits_.header_timeout_s;
      if (elapsed > limit) {
        ++stats_.header_timeouts;
        close_entry(e, Notice::header_timeout);
      }
    } else if (e.phase == Phase::body && elapsed > limits_.body_grace_s) {
      // Apache mod_reqtimeout's MinRate: after the grace period, the body must keep up.
      const double owed = double(limits_.min_body_bytes_per_s) * (elapsed - limits_.body_grace_s);
      if (double(e.body_received) < owed) {
        ++stats_.body_timeouts;
        close_entry(e, Notice::body_timeout);
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

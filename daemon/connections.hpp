// Who holds the daemon's connections, and for how long. libmicrohttpd closes a connection
// only after `connection_timeout_s` without a byte, so a client that trickles one byte a
// second keeps its connection forever, and once the connection limit is reached MHD stops
// accepting: new clients wait unanswered. This table keeps, per connection, the phase it
// is in and since when, and enforces:
//   - a header deadline: the whole request header within header_timeout_s of the
//     connection opening or of its previous reply (idle keep-alive connections included);
//   - a body rate: after body_grace_s, at least min_body_bytes_per_s on average;
//   - connection caps, per peer (uid on the Unix socket, address on TCP) and in total.
//     A new connection over a cap closes the oldest connection of that peer (or any
//     peer) that is only waiting for a request header: the newest client wins against
//     ones that are not asking anything. Connections with a request in progress are never
//     closed for room; when every one is, the new connection is answered 503.
// Closing is shutdown(2) on the socket under the table's lock, so the fd cannot have been
// reused: MHD reports a connection closed (NOTIFY_CLOSED) before it closes its socket.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::daemon {

struct ConnectionLimits {
  int max_connections = 256;
  int max_connections_per_peer = 64;
  double header_timeout_s = 10;
  double body_grace_s = 10;
  std::uint64_t min_body_bytes_per_s = 64 * 1024;
};

struct ConnectionStats {
  int open = 0;                       // registered and not being closed
  std::uint64_t evicted = 0;          // closed to make room for a newer connection
  std::uint64_t header_timeouts = 0;  // closed for a request header that did not arrive in time
  std::uint64_t body_timeouts = 0;    // closed for a body slower than the minimum rate
  std::uint64_t refused = 0;          // answered 503 because every connection was busy
};

class ConnectionTable {
 public:
  using Clock = std::chrono::steady_clock;
  using Key = const void*;  // the MHD_Connection

  explicit ConnectionTable(ConnectionLimits limits) : limits_(limits) {}

  // A new connection. Returns false when it is over a cap and nothing could be closed
  // for it: its first request is then answered 503 (see refused()).
  bool opened(Key c, int fd, std::string peer, Clock::time_point now);
  void closed(Key c);
  // The request line arrived (MHD's URI callback): the connection is asking something.
  void request_line(Key c);
  // The whole header arrived; the body (if any) follows.
  void header_complete(Key c, Clock::time_point now);
  void body_bytes(Key c, std::size_t n);
  // The request is complete and being handled (rendering, replying): no deadline here.
  void busy(Key c);
  // The reply was sent: the connection waits for its next request.
  void idle(Key c, Clock::time_point now);
  bool refused(Key c) const;

  // Closes every connection past its header deadline or below the body rate. A request
  // that was started (request line seen) gets a 408 JSON reply first; an idle keep-alive
  // connection is closed silently, as servers close idle connections.
  void enforce(Clock::time_point now);

  void set_limits(const ConnectionLimits& limits);
  ConnectionStats stats() const;

 private:
  enum class Phase { header, body, busy };
  struct Entry {
    int fd = -1;
    std::string peer;
    Phase phase = Phase::header;
    Clock::time_point since;
    bool started = false;      // the request line arrived
    bool closing = false;      // shut down by us; MHD will report it closed
    bool refused = false;
    std::uint64_t body_received = 0;
  };
  // The oldest connection waiting for a header (of `peer`, or of anyone when empty).
  Entry* oldest_waiting(const std::string& peer, Key except);
  enum class Notice { none, evicted, header_timeout, body_timeout };
  void close_entry(Entry& e, Notice notice);

  ConnectionLimits limits_;
  mutable std::mutex mu_;
  std::unordered_map<Key, Entry> entries_;
  std::unordered_map<std::string, int> per_peer_;  // open (not closing) connections per peer
  int open_ = 0;
  ConnectionStats stats_;
};

// Writes a complete HTTP/1.1 error reply (the wire table's status and JSON body,
// Connection: close) straight to a socket, without blocking: for connections the HTTP
// library is not answering itself.
void send_raw_error(int fd, const Error& error);

}  // namespace hdrd::daemon

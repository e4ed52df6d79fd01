// Who holds the daemon's connections, and for how long. libmicrohttpd closes a connection
// only after `connection_timeout_s` without a byte, so a client that trickles one byte a
// second keeps its connection forever, and once the connection limit is reached MHD stops
// accepting: new clients wait unanswered. This table keeps, per connection, the phase it
// is in and since when, and enforces:
//   - a header deadline: the whole request header within header_timeout_s of the
//     connection opening or of its previous reply (idle keep-alive connections included);
//   - a body rate: after body_grace_s, at least min_body_bytes_per_s on average;
//   - connection caps, per peer (uid on the Unix socket, address on TCP) and in total.
//
// Making room for a new connection over a cap (issue 28: 40 clients, one connection each,
// lost 12-27 of 2400 requests below the per-peer cap of 64):
//   1. Connections their clients have closed stop counting: MHD reports a close only when
//      its thread gets to that socket, and until then a new connection of the same client
//      (often on another MHD thread) found the dead one counted. They are found by polling
//      (POLLHUP; or POLLRDHUP with nothing left to read and no request in progress).
//   2. Then the oldest connection that is only waiting for a request header makes room,
//      unless its socket holds unread bytes: a connection whose request has arrived but
//      MHD has not read it yet (a busy machine) carries a request and is never closed for
//      room. A kept-alive connection idle after a reply is closed silently, as servers
//      close those (clients retry on a new connection, RFC 9112 §9.3.1); any other one
//      closed is answered 503 server.busy (Retry-After) and half-closed: a client that
//      writes its first request just then still sends it and reads the 503, not a broken
//      pipe; its read side is shut kClosedForRoomReadS later. MHD reading such a request
//      is told to drop it (closed_by_us).
//   3. Else the new connection is refused: its request is answered 503 server.busy with
//      Retry-After (HttpServer), and it does not count.
// The header deadline likewise spares a connection with unread bytes: then the server is
// behind, not the client. Connections with a request in progress are never closed for
// room.
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
  std::uint64_t hung_up = 0;          // closed by their clients, found while making room
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
  // Closed for room or a deadline: a request MHD reads from it anyway is dropped (it was
  // answered already, or it is too late).
  bool closed_by_us(Key c) const;

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
    bool served = false;       // a reply went out on it: an idle one is a kept-alive connection
    bool closing = false;      // shut down by us; MHD will report it closed
    bool half_closed = false;  // closed for room: the read side stays open a while (since = then)
    bool refused = false;
    std::uint64_t body_received = 0;
  };
  // Under mu_. Room under the cap of `peer` (the total cap when empty) for one more
  // connection, made as the header comment says; false when there is none.
  bool make_room(const std::string& peer, Key except, Clock::time_point now);
  int counted(const std::string& peer) const;
  // Closes the counted connections of `peer` (anyone's when empty) whose clients are gone.
  void close_hung_up(const std::string& peer, Key except);
  // The oldest connection of `peer` (anyone's when empty) that may be closed for room.
  Entry* oldest_evictable(const std::string& peer, Key except);
  enum class Notice { none, evicted, header_timeout, body_timeout };
  void close_entry(Entry& e, Notice notice, Clock::time_point now);

  ConnectionLimits limits_;
  mutable std::mutex mu_;
  std::unordered_map<Key, Entry> entries_;
  std::unordered_map<std::string, int> per_peer_;  // open (not closing) connections per peer
  int open_ = 0;
  ConnectionStats stats_;
};

// Writes a complete HTTP/1.1 error reply (the wire table's status and JSON body,
// Connection: close, Retry-After when positive) straight to a socket, without blocking:
// for connections the HTTP library is not answering itself.
void send_raw_error(int fd, const Error& error, int retry_after_s = 0);

}  // namespace hdrd::daemon

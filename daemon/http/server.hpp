// HTTP/1.1 transport on libmicrohttpd: one MHD daemon per listening socket (the Unix
// socket, optionally a TCP one), each with an internal polling thread pool. This layer
// owns everything MHD: request bodies are collected under a size limit while they stream
// in (413), multipart bodies are split by MHD's post processor, and a request answered
// later (a render) suspends its connection until the reply arrives. A watcher thread
// notices clients that hang up while their connection is suspended (MHD does not) and
// requests that pass their deadline, and tells the handler so the job can be cancelled.
// It also enforces the connection table's header and body deadlines (connections.hpp),
// and the table's caps decide, as each connection opens, which idle one makes room.
// Request bodies must declare their length (chunked bodies are answered 411: MHD answers
// an over-long chunk line with its own HTML 500), and query parameters must be UTF-8.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "daemon/http/connections.hpp"
#include "daemon/http/listener.hpp"
#include "daemon/http/reply.hpp"

struct MHD_Daemon;
struct MHD_Connection;

namespace hdrd::daemon {

struct Part {  // one part of a multipart/form-data body
  std::string name, filename, content_type;
  std::string data;
};

struct HttpRequest {
  std::uint64_t id = 0;
  std::string method;
  std::string path;
  std::vector<std::pair<std::string, std::string>> query;  // in order, percent-decoded
  std::map<std::string, std::string> headers;              // lower-case names
  std::string body;                                        // empty for multipart (see parts)
  std::vector<Part> parts;
  bool multipart = false;
  bool tcp = false;                                        // arrived on the TCP listener
  std::optional<PeerCred> peer;                            // Unix socket peer credentials
  std::chrono::steady_clock::time_point started;

  const std::string* header(const std::string& lower_name) const {
    auto it = headers.find(lower_name);
    return it == headers.end() ? nullptr : &it->second;
  }
};

// Where a handler sends its reply, now or later, from any thread. The first reply wins.
class Responder {
 public:
  using Clock = std::chrono::steady_clock;
  void reply(Reply r);
  // Called (once, from the watcher thread) when the client hangs up or the deadline
  // passes before a reply was sent, with the reason (request.cancelled, request.timeout).
  // Returns true when the caller may answer in its place (the job was detached); false
  // when a reply is already on its way.
  void on_abort(std::function<bool(const Error&)> f);
  void set_deadline(Clock::time_point t);
  bool replied() const;

 private:
  friend class HttpServer;
  enum class State { dispatching, suspended, done };
  void abort(const Error& why);

  mutable std::mutex mu_;
  State state_ = State::dispatching;
  std::optional<Reply> reply_;
  std::function<bool(const Error&)> on_abort_;
  std::optional<Clock::time_point> deadline_;
  MHD_Connection* connection_ = nullptr;
  int fd_ = -1;
  bool resumed_ = false;
};

class HttpHandler {
 public:
  virtual ~HttpHandler() = default;
  // Headers only (no body yet): the body limit for this request, or a reply to send at
  // once without reading the body (401, 404, 405, 413 from Content-Length, ...).
  virtual std::variant<std::size_t, Reply> begin(const HttpRequest& request) noexcept = 0;
  // The complete request. Must reply through `responder`, now or later.
  virtual void handle(HttpRequest& request, std::shared_ptr<Responder> responder) noexcept = 0;
  // After the reply was queued (access log, metrics).
  virtual void finished(const HttpRequest& request, const Reply& reply, std::size_t body_bytes) noexcept = 0;
  virtual void connection_opened(bool tcp, const std::optional<PeerCred>& peer) noexcept {}
};

struct HttpServerOptions {
  int threads = 2;
  int connection_timeout_s = 30;  // MHD's inactivity timeout (a client that stops reading a reply)
  ConnectionLimits connections;
  // Declared lengths of the bodies being received, together; beyond it 503 queue.memory.
  std::uint64_t body_budget_bytes = std::uint64_t(4) << 30;
};

class HttpServer {
 public:
  HttpServer(HttpHandler& handler, HttpServerOptions options);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Serves on `listener` (the server takes it over). Throws HdrdError when MHD refuses.
  void add_listener(Listener listener);
  // Stops accepting new connections (keeps serving open ones).
  void stop_accepting();
  // Aborts whatever is still suspended, then stops every MHD daemon.
  void stop();
  std::int64_t open_requests() const { return open_requests_.load(); }
  ConnectionStats connection_stats() const { return connections_.stats(); }
  // Caps and deadlines may change at run time (SIGHUP).
  void set_connection_limits(const ConnectionLimits& limits) { connections_.set_limits(limits); }
  void set_body_budget(std::uint64_t bytes) { body_budget_bytes_ = bytes; }

 private:
  struct Instance;
  struct RequestContext;
  struct Callbacks;  // the C callbacks MHD calls
  friend struct Callbacks;
  int on_access(Instance& inst, MHD_Connection* c, const char* url, const char* method, const char* version,
                const char* upload_data, std::size_t* upload_data_size, void** con_cls);
  int begin_request(Instance& inst, MHD_Connection* c, const char* url, const char* method, const char* version,
                    RequestContext& ctx);
  void collect_body(MHD_Connection* c, RequestContext& ctx, const char* data, std::size_t size);
  std::optional<Reply> refuse_early(MHD_Connection* c, const HttpRequest& req);
  std::optional<Reply> split_multipart(MHD_Connection* c, RequestContext& ctx);
  int dispatch(MHD_Connection* c, RequestContext& ctx);
  int queue(MHD_Connection* c, RequestContext& ctx, const Reply& r);
  void watch(std::shared_ptr<Responder> r);
  void watcher_loop();

  HttpHandler& handler_;
  HttpServerOptions options_;
  ConnectionTable connections_;
  std::atomic<std::uint64_t> body_budget_bytes_;
  std::atomic<std::uint64_t> body_bytes_reserved_{0};
  std::vector<std::unique_ptr<Instance>> instances_;
  std::atomic<std::uint64_t> next_id_{1};
  std::atomic<std::int64_t> open_requests_{0};

  std::mutex watch_mu_;
  std::vector<std::shared_ptr<Responder>> watched_;
  std::atomic<bool> stop_watcher_{false};
  std::thread watcher_;
};

}  // namespace hdrd::daemon

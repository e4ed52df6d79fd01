#include "daemon/http/server.hpp"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>

#include <algorithm>
#include <cctype>
#include <cstdarg>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/http/input_bounds.hpp"

namespace hdrd::daemon {

struct HttpServer::Instance {
  HttpServer* server = nullptr;
  Listener listener;
  MHD_Daemon* daemon = nullptr;
  bool tcp = false;
  bool quiesced = false;
};

struct HttpServer::RequestContext {
  HttpRequest req;
  std::size_t limit = 0;
  bool too_large = false;
  bool busy = false;  // refused for room: the body is read and dropped, then 503
  bool queued = false;
  std::shared_ptr<Responder> responder;
  std::uint64_t reserved = 0;  // of the body budget, given back when the request ends
  HttpServer* server = nullptr;
  ~RequestContext() {
    if (server) server->body_bytes_reserved_ -= reserved;
  }
};

namespace {

struct ConnectionInfo {
  std::optional<PeerCred> peer;
  // The current request's target as the client sent it (MHD's URI callback, before it
  // percent-decodes the path in place), and where it starts in MHD's read buffer.
  std::string raw_target;
  const char* raw_target_at = nullptr;
};

// Oversized bodies up to this much beyond the limit are read and dropped before the 413.
constexpr unsigned long long kDrainLimitBytes = 16ull << 20;

// The request's Content-Length when it is one plain decimal number (RFC 9110 §8.6:
// 1*DIGIT). Repeated fields arrive joined by ", " (collect_header), so they are not.
std::optional<unsigned long long> declared_length(const HttpRequest& req) {
  const auto* cl = req.header("content-length");
  if (!cl || cl->empty() || cl->size() > 19) return std::nullopt;
  unsigned long long n = 0;
  for (char ch : *cl) {
    if (ch < '0' || ch > '9') return std::nullopt;
    n = n * 10 + unsigned(ch - '0');
  }
  return n;
}

// A request whose framing is in doubt is answered and its connection closed: the rest of
// what the client sent cannot be trusted to start a request (RFC 9112 §6.3 item 5).
Reply bad_framing(Error e) {
  Reply r = Reply::error(std::move(e));
  r.headers.emplace_back("Connection", "close");
  return r;
}

// The framing and the target, before anything else looks at the request.
// - Content-Length must be a single decimal number. Two fields are refused even when they
//   agree (RFC 9110 §8.6 allows either): libmicrohttpd frames the body by the first, a
//   proxy in front may frame it by another, and no client needs to send two.
// - The target holds no control byte, raw or percent-encoded (check_request_target). A raw
//   NUL hides the rest of the target from the URI callback too ("GET /v1/status\0x"): MHD
//   cuts the request line into C strings in its read buffer, so the version starts right
//   after the target's last byte; when the target seen is shorter than that span, the
//   request line held a NUL.
std::optional<Reply> refuse_malformed(const HttpRequest& req, const ConnectionInfo* info, const char* version) {
  if (req.header("content-length") && !declared_length(req))
    return bad_framing(make_error("request.content_length",
                                  fmt::format("Content-Length must be one decimal number; got '{}'",
                                              req.header("content-length")->substr(0, 64)), "content-length"));
  if (!info) return std::nullopt;
  if (auto t = check_request_target(info->raw_target); !t) return bad_framing(t.error());
  if (info->raw_target_at && version && *version && version > info->raw_target_at &&
      std::size_t(version - info->raw_target_at) < (std::size_t(1) << 20) &&
      std::size_t(version - info->raw_target_at) - 1 > info->raw_target.size())
    return bad_framing(make_error("request.target", fmt::format("the request target holds control byte 0x00 at "
                                                                "offset {}", info->raw_target.size())));
  return std::nullopt;
}

// The connection was refused for room: answered, then closed (it does not count, and the
// client's next connection may find room).
Reply busy_reply() {
  Reply busy = Reply::error(make_error("server.busy", "every connection is busy with a request; retry later"));
  busy.headers.emplace_back("Retry-After", "1");
  busy.headers.emplace_back("Connection", "close");
  return busy;
}

Reply too_large_reply(std::size_t limit) {
  return Reply::error(make_error("request.too_large",
                                 fmt::format("request body exceeds the limit of {} bytes", limit)));
}

void mhd_log(void*, const char* fmt_str, va_list ap) {
  char buf[512];
  std::vsnprintf(buf, sizeof buf, fmt_str, ap);
  std::string s(buf);
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  spdlog::debug("libmicrohttpd: {}", s);
}

MHD_Result collect_header(void* cls, MHD_ValueKind, const char* key, const char* value) {
  auto& headers = *static_cast<std::map<std::string, std::string>*>(cls);
  std::string k(key ? key : "");
  std::transform(k.begin(), k.end(), k.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
  auto [it, fresh] = headers.emplace(std::move(k), value ? value : "");
  if (!fresh) it->second += std::string(", ") + (value ? value : "");  // RFC 9110 §5.3
  return MHD_YES;
}

// With their lengths: a %00 in a value must reach check_query, not end the string there.
MHD_Result collect_query(void* cls, MHD_ValueKind, const char* key, size_t key_size, const char* value,
                         size_t value_size) {
  auto& q = *static_cast<std::vector<std::pair<std::string, std::string>>*>(cls);
  q.emplace_back(std::string(key ? key : "", key ? key_size : 0), std::string(value ? value : "", value ? value_size : 0));
  return MHD_YES;
}

// Who a connection belongs to, for the per-peer cap: the uid on a Unix socket (SO_PEERCRED),
// the address on TCP.
std::string peer_key(MHD_Connection* c, const std::optional<PeerCred>& cred) {
  if (cred) return fmt::format("uid:{}", cred->uid);
  const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
  if (!ci || !ci->client_addr) return "unknown";
  char text[INET6_ADDRSTRLEN] = {};
  const sockaddr* a = ci->client_addr;
  if (a->sa_family == AF_INET) ::inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a)->sin_addr, text, sizeof text);
  else if (a->sa_family == AF_INET6)
    ::inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(a)->sin6_addr, text, sizeof text);
  return fmt::format("ip:{}", text);
}

// epoll serves thousands of connections, select()'s FD_SETSIZE does not matter; the open
// file limit does. The soft limit is raised to the hard one (systemd's default hard limit
// is 524288), and MHD's own connection limit stays below it with room for files and GL.
// MHD's own limit is only a backstop far above the table's caps (which may grow on reload):
// at it, MHD stops accepting. It costs nothing until connections exist.
unsigned hard_connection_limit() {
  rlimit rl{};
  if (::getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
    rl.rlim_cur = rl.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &rl);
    ::getrlimit(RLIMIT_NOFILE, &rl);
  }
  // 128 descriptors stay for files, GL and the listeners.
  return rl.rlim_cur > 256 ? unsigned(std::min<rlim_t>(rl.rlim_cur - 128, 1u << 17)) : 128u;
}

struct PostState {
  std::vector<Part>* parts;
  std::size_t total = 0, limit = 0;
  bool overflow = false;
};

MHD_Result collect_part(void* cls, MHD_ValueKind, const char* key, const char* filename, const char* content_type,
                        const char*, const char* data, uint64_t off, size_t size) {
  auto& st = *static_cast<PostState*>(cls);
  auto& parts = *st.parts;
  const std::string name = key ? key : "";
  if (off == 0 || parts.empty() || parts.back().name != name) {
    if (parts.size() >= 16) {
      st.overflow = true;
      return MHD_NO;
    }
    parts.push_back({name, filename ? filename : "", content_type ? content_type : "", {}});
  }
  st.total += size;
  if (st.total > st.limit) {
    st.overflow = true;
    return MHD_NO;
  }
  parts.back().data.append(data, size);
  return MHD_YES;
}

// Header values come partly from data (scene names, warnings): no control characters may
// reach the wire (RFC 9110 §5.5), so they become spaces.
std::string header_safe(std::string v) {
  for (char& ch : v)
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = ' ';
  return v;
}

void free_body(void* cls) { delete static_cast<std::shared_ptr<const std::string>*>(cls); }
void free_bytes(void* cls) { delete static_cast<std::shared_ptr<const std::vector<std::uint8_t>>*>(cls); }

}  // namespace

// ---- Responder ----------------------------------------------------------------------

void Responder::reply(Reply r) {
  std::function<bool(const Error&)> abort_fn;  // released outside the lock
  std::lock_guard lock(mu_);
  if (reply_) return;
  reply_ = std::move(r);
  abort_fn.swap(on_abort_);
  if (state_ == State::suspended) {
    state_ = State::done;
    resumed_ = true;
    MHD_resume_connection(connection_);
  }
}

void Responder::on_abort(std::function<bool(const Error&)> f) {
  std::lock_guard lock(mu_);
  on_abort_ = std::move(f);
}

void Responder::set_deadline(Clock::time_point t) {
  std::lock_guard lock(mu_);
  deadline_ = t;
}

bool Responder::replied() const {
  std::lock_guard lock(mu_);
  return reply_.has_value();
}

void Responder::abort(const Error& why) {
  std::function<bool(const Error&)> f;
  {
    std::lock_guard lock(mu_);
    if (reply_) return;
    f = on_abort_;
  }
  if (f && !f(why)) return;  // the job's reply is being delivered right now
  reply(Reply::error(why));
}

// ---- HttpServer ---------------------------------------------------------------------

struct HttpServer::Callbacks {
  static MHD_Result access(void* cls, MHD_Connection* c, const char* url, const char* method, const char* version,
                           const char* upload_data, size_t* upload_data_size, void** con_cls) {
    auto& inst = *static_cast<Instance*>(cls);
    return inst.server->on_access(inst, c, url, method, version, upload_data, upload_data_size, con_cls) ? MHD_YES
                                                                                                         : MHD_NO;
  }
  // Called when the request line has arrived, with the target as sent; its return value is
  // MHD's initial con_cls, which must stay null (on_access takes null for "first call").
  static void* uri_logged(void* cls, const char* uri, MHD_Connection* c) {
    if (const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT))
      if (auto* info = static_cast<ConnectionInfo*>(ci->socket_context)) {
        info->raw_target = uri ? uri : "";
        info->raw_target_at = uri;
      }
    static_cast<Instance*>(cls)->server->connections_.request_line(c);
    return nullptr;
  }
  static void completed(void* cls, MHD_Connection* c, void** con_cls, MHD_RequestTerminationCode toe) {
    auto& inst = *static_cast<Instance*>(cls);
    inst.server->connections_.idle(c, std::chrono::steady_clock::now());
    auto* ctx = static_cast<RequestContext*>(*con_cls);
    if (!ctx) return;
    if (toe != MHD_REQUEST_TERMINATED_COMPLETED_OK)
      spdlog::debug("request {} {} {} ended early (reason {})", ctx->req.id, ctx->req.method, ctx->req.path, int(toe));
    delete ctx;
    *con_cls = nullptr;
    --inst.server->open_requests_;
  }
  static void connection(void* cls, MHD_Connection* c, void** socket_context, MHD_ConnectionNotificationCode toe) {
    auto& inst = *static_cast<Instance*>(cls);
    if (toe == MHD_CONNECTION_NOTIFY_STARTED) {
      auto* info = new ConnectionInfo;
      if (const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD))
        info->peer = peer_credentials(ci->connect_fd);
      *socket_context = info;
      const auto* fd = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
      inst.server->connections_.opened(c, fd ? fd->connect_fd : -1, peer_key(c, info->peer),
                                       std::chrono::steady_clock::now());
      inst.server->handler_.connection_opened(inst.tcp, info->peer);
    } else {
      inst.server->connections_.closed(c);
      delete static_cast<ConnectionInfo*>(*socket_context);
      *socket_context = nullptr;
    }
  }
};

HttpServer::HttpServer(HttpHandler& handler, HttpServerOptions options)
    : handler_(handler), options_(options), connections_(options.connections),
      body_budget_bytes_(options.body_budget_bytes) {
  watcher_ = std::thread([this] { watcher_loop(); });
}

HttpServer::~HttpServer() { stop(); }

void HttpServer::add_listener(Listener listener) {
  auto inst = std::make_unique<Instance>();
  inst->server = this;
  inst->tcp = !listener.is_unix();
  inst->listener = std::move(listener);
  const unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
  inst->daemon = MHD_start_daemon(
      flags, 0, nullptr, nullptr, &Callbacks::access, inst.get(),
      MHD_OPTION_LISTEN_SOCKET, MHD_socket(inst->listener.fd()),
      MHD_OPTION_THREAD_POOL_SIZE, unsigned(options_.threads),
      MHD_OPTION_CONNECTION_TIMEOUT, unsigned(options_.connection_timeout_s),
      MHD_OPTION_CONNECTION_LIMIT, hard_connection_limit(),
      MHD_OPTION_URI_LOG_CALLBACK, &Callbacks::uri_logged, inst.get(),
      MHD_OPTION_CONNECTION_MEMORY_LIMIT, std::size_t(64 * 1024),
      MHD_OPTION_NOTIFY_COMPLETED, &Callbacks::completed, inst.get(),
      MHD_OPTION_NOTIFY_CONNECTION, &Callbacks::connection, inst.get(),
      MHD_OPTION_EXTERNAL_LOGGER, &mhd_log, nullptr,
      MHD_OPTION_END);
  if (!inst->daemon)
    throw HdrdError(make_error("server.start", "libmicrohttpd could not start on " + inst->listener.description()));
  spdlog::info("listening on {}", inst->listener.description());
  instances_.push_back(std::move(inst));
}

void HttpServer::stop_accepting() {
  for (auto& inst : instances_) {
    if (!inst->daemon || inst->quiesced) continue;
    MHD_quiesce_daemon(inst->daemon);  // hands the listen fd back; the Listener still owns it
    inst->quiesced = true;
    inst->listener.close();            // and removes the socket file
  }
}

void HttpServer::stop() {
  stop_accepting();
  {
    std::vector<std::shared_ptr<Responder>> pending;
    {
      std::lock_guard lock(watch_mu_);
      pending = watched_;
    }
    for (auto& r : pending) r->abort(make_error("server.draining", "the daemon is shutting down"));
  }
  // Let resumed connections send their replies.
  for (int i = 0; i < 200 && open_requests_.load() > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  for (auto& inst : instances_)
    if (inst->daemon) {
      MHD_stop_daemon(inst->daemon);
      inst->daemon = nullptr;
    }
  instances_.clear();
  stop_watcher_ = true;
  if (watcher_.joinable()) watcher_.join();
}

int HttpServer::queue(MHD_Connection* c, RequestContext& ctx, const Reply& r) {
  ctx.queued = true;
  MHD_Response* resp = nullptr;
  if (r.file) {  // streamed from a descriptor of MHD's own, which it closes
    const int fd = ::dup(r.file->fd);
    if (fd < 0) return MHD_NO;
    resp = MHD_create_response_from_fd(r.file->size, fd);
    if (!resp) {
      ::close(fd);
      return MHD_NO;
    }
  } else if (r.bytes) {  // MHD sends from the job's own buffer and frees it with the response
    auto* holder = new std::shared_ptr<const std::vector<std::uint8_t>>(r.bytes);
    resp = MHD_create_response_from_buffer_with_free_callback_cls(
        (*holder)->size(), const_cast<std::uint8_t*>((*holder)->data()), &free_bytes, holder);
    if (!resp) {
      delete holder;
      return MHD_NO;
    }
  } else {
    auto* holder = new std::shared_ptr<const std::string>(r.body);
    resp = MHD_create_response_from_buffer_with_free_callback_cls((*holder)->size(), const_cast<char*>((*holder)->data()),
                                                                  &free_body, holder);
    if (!resp) {
      delete holder;
      return MHD_NO;
    }
  }
  MHD_add_response_header(resp, "Content-Type", r.content_type.c_str());
  MHD_add_response_header(resp, "X-Hdrd-Request-Id", std::to_string(ctx.req.id).c_str());
  for (const auto& [k, v] : r.headers) MHD_add_response_header(resp, k.c_str(), header_safe(v).c_str());
  const MHD_Result ok = MHD_queue_response(c, r.status, resp);
  MHD_destroy_response(resp);
  handler_.finished(ctx.req, r, ctx.req.body.size());
  return ok == MHD_YES;
}

// First call for a request: headers only. Decides the body limit (or answers at once).
int HttpServer::begin_request(Instance& inst, MHD_Connection* c, const char* url, const char* method,
                              const char* version, RequestContext& ctx) {
  ++open_requests_;
  // Closed for room after MHD had read this request: it was answered 503 then.
  if (connections_.closed_by_us(c)) return MHD_NO;
  auto& req = ctx.req;
  req.id = next_id_++;
  req.method = method ? method : "";
  req.path = url ? url : "";
  req.tcp = inst.tcp;
  req.started = std::chrono::steady_clock::now();
  MHD_get_connection_values(c, MHD_HEADER_KIND, &collect_header, &req.headers);
  MHD_get_connection_values_n(c, MHD_GET_ARGUMENT_KIND, &collect_query, &req.query);
  const ConnectionInfo* info = nullptr;
  if (const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT))
    info = static_cast<const ConnectionInfo*>(ci->socket_context);
  if (info) req.peer = info->peer;
  connections_.header_complete(c, req.started);
  if (auto bad = refuse_malformed(req, info, version)) return queue(c, ctx, *bad);
  if (connections_.refused(c)) {
    // Like an oversized body below: a body of modest size is read and dropped first, so
    // that a client which sends before it reads sees the 503, not a broken pipe.
    const unsigned long long n = declared_length(req).value_or(0);
    if (n == 0 || n > kDrainLimitBytes || req.header("expect")) return queue(c, ctx, busy_reply());
    ctx.busy = true;
    return MHD_YES;
  }
  auto pre = handler_.begin(req);
  if (auto* r = std::get_if<Reply>(&pre)) return queue(c, ctx, *r);
  if (auto bad = refuse_early(c, req)) return queue(c, ctx, *bad);
  ctx.limit = std::get<std::size_t>(pre);
  if (const auto length = declared_length(req)) {
    const unsigned long long n = *length;
    if (n > ctx.limit) {
      // A client that waits for "100 Continue", or one about to send far too much, is
      // answered at once (and the connection closed). A modestly oversized body is read
      // and dropped first, so that simple clients which send before they read still
      // see the 413 instead of a broken pipe.
      if (req.header("expect") || n > ctx.limit + kDrainLimitBytes) return queue(c, ctx, too_large_reply(ctx.limit));
      ctx.too_large = true;
    } else if (n > 0) {
      // Bodies being received count against the memory budget too: a hundred clients
      // uploading at once would otherwise hold gigabytes before any job is admitted.
      const std::uint64_t budget = body_budget_bytes_.load();
      if (body_bytes_reserved_.fetch_add(n) + n > budget) {
        body_bytes_reserved_ -= n;
        Reply busy = Reply::error(make_error("queue.memory", fmt::format("request bodies being received hold the "
                                                                         "memory budget of {} bytes; retry later", budget)));
        busy.headers.emplace_back("Retry-After", "1");
        return queue(c, ctx, busy);
      }
      ctx.reserved = n;
      ctx.server = this;
      // One allocation of the declared size instead of a string that doubles as it grows
      // (and so holds up to twice the body at its peak). Pages are touched as bytes arrive.
      try {
        req.body.reserve(std::size_t(n));
      } catch (const std::bad_alloc&) {
        return queue(c, ctx, Reply::error(make_error("queue.memory", "no memory for the request body; retry later")));
      }
    }
  }
  return MHD_YES;
}

// What the HTTP layer refuses before the handler reads a byte of the body.
std::optional<Reply> HttpServer::refuse_early(MHD_Connection*, const HttpRequest& req) {
  if (const auto* te = req.header("transfer-encoding"); te && !te->empty())
    return Reply::error(make_error("request.length_required",
                                   "request bodies must carry Content-Length (Transfer-Encoding is not accepted)",
                                   "transfer-encoding"));
  if (auto q = check_query(req.query); !q) return Reply::error(q.error());
  return std::nullopt;
}

// Body bytes as they stream in, kept up to the limit; beyond it they are dropped.
void HttpServer::collect_body(MHD_Connection* c, RequestContext& ctx, const char* data, std::size_t size) {
  connections_.body_bytes(c, size);
  if (ctx.too_large || ctx.busy || ctx.queued) return;
  if (ctx.req.body.size() + size > ctx.limit) {
    ctx.too_large = true;
    std::string().swap(ctx.req.body);
  } else {
    ctx.req.body.append(data, size);
  }
}

// multipart/form-data bodies are split into parts by MHD's post processor.
std::optional<Reply> HttpServer::split_multipart(MHD_Connection* c, RequestContext& ctx) {
  auto& req = ctx.req;
  const auto* ct = req.header("content-type");
  if (!ct || ct->rfind("multipart/form-data", 0) != 0) return std::nullopt;
  req.multipart = true;
  PostState st{&req.parts, 0, ctx.limit};
  MHD_PostProcessor* pp = MHD_create_post_processor(c, 64 * 1024, &collect_part, &st);
  bool ok = pp != nullptr;
  if (pp) {
    ok = MHD_post_process(pp, req.body.data(), req.body.size()) == MHD_YES;
    ok = (MHD_destroy_post_processor(pp) == MHD_YES) && ok;
  }
  std::string().swap(req.body);
  if (st.overflow) return Reply::error(make_error("request.limit", "multipart body: too many or too large parts"));
  if (!ok) return Reply::error(make_error("request.syntax", "malformed multipart/form-data body"));
  return std::nullopt;
}

// The complete request goes to the handler; a reply that is not there when it returns
// arrives later, so the connection is suspended until then.
int HttpServer::dispatch(MHD_Connection* c, RequestContext& ctx) {
  auto responder = std::make_shared<Responder>();
  responder->connection_ = c;
  if (const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD)) responder->fd_ = ci->connect_fd;
  ctx.responder = responder;
  connections_.busy(c);
  handler_.handle(ctx.req, responder);
  {
    std::unique_lock lock(responder->mu_);
    if (responder->reply_) {
      responder->state_ = Responder::State::done;
      Reply r = *responder->reply_;
      lock.unlock();
      return queue(c, ctx, r);
    }
    responder->state_ = Responder::State::suspended;
    MHD_suspend_connection(c);
  }
  watch(responder);
  return MHD_YES;
}

int HttpServer::on_access(Instance& inst, MHD_Connection* c, const char* url, const char* method, const char* version,
                          const char* upload_data, std::size_t* upload_data_size, void** con_cls) {
  auto* ctx = static_cast<RequestContext*>(*con_cls);
  if (!ctx) {
    ctx = new RequestContext;
    *con_cls = ctx;
    return begin_request(inst, c, url, method, version, *ctx);
  }
  if (*upload_data_size > 0) {
    collect_body(c, *ctx, upload_data, *upload_data_size);
    *upload_data_size = 0;
    return MHD_YES;
  }
  if (ctx->queued) return MHD_YES;
  if (ctx->responder) {  // resumed: the reply is there
    std::optional<Reply> r;
    {
      std::lock_guard lock(ctx->responder->mu_);
      r = ctx->responder->reply_;
    }
    return queue(c, *ctx, r ? *r : Reply::error(make_error("internal", "resumed without a reply")));
  }
  if (ctx->busy) return queue(c, *ctx, busy_reply());
  if (ctx->too_large) return queue(c, *ctx, too_large_reply(ctx->limit));
  if (auto bad = split_multipart(c, *ctx)) return queue(c, *ctx, *bad);
  return dispatch(c, *ctx);
}

void HttpServer::watch(std::shared_ptr<Responder> r) {
  std::lock_guard lock(watch_mu_);
  watched_.push_back(std::move(r));
}

// MHD does not look at suspended connections, so a client that hangs up during a long
// render would go unnoticed: poll their sockets for POLLRDHUP/POLLHUP, and enforce
// deadlines, every 20 ms; the connection table's header and body deadlines every 100 ms.
void HttpServer::watcher_loop() {
  std::vector<std::shared_ptr<Responder>> list;
  std::vector<pollfd> fds;
  auto next_enforce = std::chrono::steady_clock::now();
  while (!stop_watcher_) {
    if (const auto now = std::chrono::steady_clock::now(); now >= next_enforce) {
      connections_.enforce(now);
      next_enforce = now + std::chrono::milliseconds(100);
    }
    {
      std::lock_guard lock(watch_mu_);
      watched_.erase(std::remove_if(watched_.begin(), watched_.end(), [](const auto& r) { return r->replied(); }),
                     watched_.end());
      list = watched_;
    }
    fds.clear();
    for (const auto& r : list) fds.push_back({r->fd_, POLLRDHUP, 0});
    ::poll(fds.data(), fds.size(), 20);
    const auto now = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < list.size(); ++i) {
      auto& r = list[i];
      if (fds[i].revents & (POLLHUP | POLLRDHUP | POLLERR | POLLNVAL)) {
        r->abort(make_error("request.cancelled", "the client closed the connection"));
        continue;
      }
      std::optional<Responder::Clock::time_point> deadline;
      {
        std::lock_guard lock(r->mu_);
        deadline = r->deadline_;
      }
      if (deadline && now > *deadline) r->abort(make_error("request.timeout", "the request exceeded its time limit"));
    }
  }
}

}  // namespace hdrd::daemon

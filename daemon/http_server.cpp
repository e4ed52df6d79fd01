#include "daemon/http_server.hpp"

#include <microhttpd.h>
#include <poll.h>

#include <algorithm>
#include <cctype>
#include <cstdarg>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

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
  bool queued = false;
  std::shared_ptr<Responder> responder;
};

namespace {

struct ConnectionInfo {
  std::optional<PeerCred> peer;
};

// Oversized bodies up to this much beyond the limit are read and dropped before the 413.
constexpr unsigned long long kDrainLimitBytes = 16ull << 20;

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

MHD_Result collect_query(void* cls, MHD_ValueKind, const char* key, const char* value) {
  auto& q = *static_cast<std::vector<std::pair<std::string, std::string>>*>(cls);
  q.emplace_back(key ? key : "", value ? value : "");
  return MHD_YES;
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
  static MHD_Result access(void* cls, MHD_Connection* c, const char* url, const char* method, const char*,
                           const char* upload_data, size_t* upload_data_size, void** con_cls) {
    auto& inst = *static_cast<Instance*>(cls);
    return inst.server->on_access(inst, c, url, method, upload_data, upload_data_size, con_cls) ? MHD_YES : MHD_NO;
  }
  static void completed(void* cls, MHD_Connection*, void** con_cls, MHD_RequestTerminationCode toe) {
    auto& inst = *static_cast<Instance*>(cls);
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
      inst.server->handler_.connection_opened(inst.tcp, info->peer);
    } else {
      delete static_cast<ConnectionInfo*>(*socket_context);
      *socket_context = nullptr;
    }
  }
};

HttpServer::HttpServer(HttpHandler& handler, HttpServerOptions options) : handler_(handler), options_(options) {
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
      MHD_OPTION_CONNECTION_LIMIT, unsigned(options_.max_connections),
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
  auto* holder = new std::shared_ptr<const std::string>(r.body);
  MHD_Response* resp = MHD_create_response_from_buffer_with_free_callback_cls(
      (*holder)->size(), const_cast<char*>((*holder)->data()), &free_body, holder);
  if (!resp) {
    delete holder;
    return MHD_NO;
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
                              RequestContext& ctx) {
  ++open_requests_;
  auto& req = ctx.req;
  req.id = next_id_++;
  req.method = method ? method : "";
  req.path = url ? url : "";
  req.tcp = inst.tcp;
  req.started = std::chrono::steady_clock::now();
  MHD_get_connection_values(c, MHD_HEADER_KIND, &collect_header, &req.headers);
  MHD_get_connection_values(c, MHD_GET_ARGUMENT_KIND, &collect_query, &req.query);
  if (const auto* ci = MHD_get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT))
    if (ci->socket_context) req.peer = static_cast<ConnectionInfo*>(ci->socket_context)->peer;
  auto pre = handler_.begin(req);
  if (auto* r = std::get_if<Reply>(&pre)) return queue(c, ctx, *r);
  ctx.limit = std::get<std::size_t>(pre);
  if (const auto* cl = req.header("content-length")) {
    char* end = nullptr;
    const unsigned long long n = std::strtoull(cl->c_str(), &end, 10);
    if (end && *end == '\0' && n > ctx.limit) {
      // A client that waits for "100 Continue", or one about to send far too much, is
      // answered at once (and the connection closed). A modestly oversized body is read
      // and dropped first, so that simple clients which send before they read still
      // see the 413 instead of a broken pipe.
      if (req.header("expect") || n > ctx.limit + kDrainLimitBytes) return queue(c, ctx, too_large_reply(ctx.limit));
      ctx.too_large = true;
    }
  }
  return MHD_YES;
}

// Body bytes as they stream in, kept up to the limit; beyond it they are dropped.
void HttpServer::collect_body(RequestContext& ctx, const char* data, std::size_t size) {
  if (ctx.too_large || ctx.queued) return;
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

int HttpServer::on_access(Instance& inst, MHD_Connection* c, const char* url, const char* method,
                          const char* upload_data, std::size_t* upload_data_size, void** con_cls) {
  auto* ctx = static_cast<RequestContext*>(*con_cls);
  if (!ctx) {
    ctx = new RequestContext;
    *con_cls = ctx;
    return begin_request(inst, c, url, method, *ctx);
  }
  if (*upload_data_size > 0) {
    collect_body(*ctx, upload_data, *upload_data_size);
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
// deadlines, every 20 ms.
void HttpServer::watcher_loop() {
  std::vector<std::shared_ptr<Responder>> list;
  std::vector<pollfd> fds;
  while (!stop_watcher_) {
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

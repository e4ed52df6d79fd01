// Service lifecycle: sockets, workers, HTTP server, reload and drain. The endpoint
// handlers are in api.cpp.
#include "daemon/service.hpp"

#include <malloc.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/jobs/render_worker.hpp"

namespace fs = std::filesystem;

namespace hdrd::daemon {
namespace {

std::string read_token(const ServerConfig& s) {
  if (!s.token.empty()) return s.token;
  if (s.token_file.empty()) return {};
  std::ifstream in(s.token_file);
  if (!in) throw HdrdError(make_error("config.invalid", "cannot read server.token_file " + s.token_file.string(),
                                      "server.token_file"));
  std::string t;
  std::getline(in, t);
  while (!t.empty() && (t.back() == '\r' || t.back() == ' ')) t.pop_back();
  if (t.size() < 16)
    throw HdrdError(make_error("config.invalid", "server.token_file: the token must be at least 16 characters",
                               "server.token_file"));
  return t;
}

bool is_unix_socket(int fd) {
  sockaddr_storage ss{};
  socklen_t len = sizeof ss;
  return ::getsockname(fd, reinterpret_cast<sockaddr*>(&ss), &len) == 0 && ss.ss_family == AF_UNIX;
}

}  // namespace

void set_log_level(const std::string& level) { spdlog::set_level(spdlog::level::from_str(level)); }

Service::Service(Config config) : config_(std::make_shared<const Config>(std::move(config))) {}

Service::~Service() {
  if (server_ || scheduler_) shutdown();
}

std::shared_ptr<const Config> Service::config() const {
  std::lock_guard lock(config_mu_);
  return config_;
}

// Where frame-sized buffers live decides both speed and memory. With a threshold of 1 MiB
// every one had its own mapping, returned when freed, so every request faulted its ~200 MB
// in afresh: ~50 000 page faults for a 4K /v1/encode, most of what the daemon added to the
// same work in-process. With 256 MiB (fixed, which also turns glibc's own adjustment off)
// they come from the arenas, and the next job reuses them; the scheduler hands the free
// memory back once the daemon has been idle for trim_idle after a large job
// (Scheduler::trim_loop), so that a burst does not stay resident (docs/performance-daemon.md,
// "Memory"). Blocks larger than an arena's heap (64 MiB) are still mapped on their own.
constexpr int kMmapThresholdBytes = 256 << 20;

void Service::start() {
  if (::mallopt(M_MMAP_THRESHOLD, kMmapThresholdBytes) != 1) spdlog::warn("glibc refused an mmap threshold of 256 MiB");
  auto cfg = config();
  set_log_level(cfg->log.level);
  token_ = read_token(cfg->server);
  check_config_paths(*cfg);  // a dump directory that cannot be written stops the start, not the first dump
  if (!cfg->paths.dump_dir.empty()) dump_dir_ = std::make_unique<DumpDirectory>(cfg->paths.dump_dir);

  std::vector<Listener> listeners;
  if (cfg->server.systemd_activation) {
    for (int fd : systemd_listen_fds()) {
      const bool unix_socket = is_unix_socket(fd);
      listeners.emplace_back(fd, fmt::format("systemd fd {} ({})", fd, unix_socket ? "unix" : "tcp"), unix_socket);
    }
    if (!listeners.empty()) spdlog::info("socket activation: {} inherited socket(s)", listeners.size());
  }
  if (listeners.empty()) {
    const fs::path path = cfg->server.socket_path.empty() ? default_socket_path() : cfg->server.socket_path;
    listeners.push_back(listen_unix(path, cfg->server.socket_mode, cfg->server.socket_group));
  }
  if (!cfg->server.tcp_listen.empty())
    listeners.push_back(listen_tcp(cfg->server.tcp_listen, cfg->server.tcp_allow_non_loopback));
  for (const auto& l : listeners)
    if (!l.is_unix() && token_.empty())
      throw HdrdError(make_error("config.invalid", "a TCP listener needs server.token or server.token_file",
                                 "server.token"));

  SchedulerOptions so;
  so.render_workers = cfg->workers.render_workers;
  so.encode_threads = cfg->workers.encode_threads;
  so.queue_depth = cfg->workers.queue_depth;
  so.coalesce = cfg->workers.coalesce;
  so.memory_budget_bytes = effective_memory_budget(cfg->workers);
  scheduler_ = std::make_unique<Scheduler>(so, renderer_factory(cfg->workers.backend));
  scheduler_->start();
  JobRegistryOptions jo;
  jo.max_running = cfg->sequences.max_running;
  jo.max_queued = cfg->sequences.max_queued;
  jo.history = cfg->sequences.history;
  jo.memory_budget_bytes = so.memory_budget_bytes;
  jo.backend = cfg->workers.backend;
  jobs_ = std::make_unique<JobRegistry>(jo);
  cluster_ = new_cluster_state();

  HttpServerOptions ho;
  ho.threads = cfg->server.http_threads;
  ho.connection_timeout_s = cfg->server.connection_timeout_s;
  ho.connections = connection_limits(cfg->server);
  ho.body_budget_bytes = so.memory_budget_bytes;
  server_ = std::make_unique<HttpServer>(*this, ho);
  for (auto& l : listeners) {
    listener_descriptions_.push_back(l.description());
    server_->add_listener(std::move(l));
  }
  started_ = std::chrono::steady_clock::now();
}

void Service::reload(Config fresh) {
  check_config_paths(fresh);  // throws: the reload is refused and the old configuration kept
  auto old = config();
  auto restart_needed = [&](bool changed, const char* key) {
    if (changed) spdlog::warn("reload: {} changed; it takes effect after a restart", key);
  };
  restart_needed(fresh.server.socket_path != old->server.socket_path, "server.socket_path");
  restart_needed(fresh.server.tcp_listen != old->server.tcp_listen, "server.tcp_listen");
  restart_needed(fresh.server.http_threads != old->server.http_threads, "server.http_threads");
  restart_needed(fresh.server.connection_timeout_s != old->server.connection_timeout_s, "server.connection_timeout_s");
  restart_needed(fresh.workers.render_workers != old->workers.render_workers, "workers.render_workers");
  restart_needed(fresh.workers.encode_threads != old->workers.encode_threads, "workers.encode_threads");
  restart_needed(fresh.workers.backend != old->workers.backend, "workers.backend");
  restart_needed(fresh.sequences.max_running != old->sequences.max_running, "sequences.max_running");
  // Keep what cannot change now, so that status reports what is really in effect; the
  // connection caps and deadlines do change at once.
  const ServerConfig applied = fresh.server;
  fresh.server = old->server;
  fresh.server.max_connections = applied.max_connections;
  fresh.server.max_connections_per_peer = applied.max_connections_per_peer;
  fresh.server.header_timeout_s = applied.header_timeout_s;
  fresh.server.body_grace_s = applied.body_grace_s;
  fresh.server.min_body_bytes_per_s = applied.min_body_bytes_per_s;
  fresh.workers.render_workers = old->workers.render_workers;
  fresh.workers.encode_threads = old->workers.encode_threads;
  fresh.workers.backend = old->workers.backend;
  fresh.sequences.max_running = old->sequences.max_running;
  if (fresh.paths.dump_dir != old->paths.dump_dir)
    dump_dir_ = fresh.paths.dump_dir.empty() ? nullptr : std::make_unique<DumpDirectory>(fresh.paths.dump_dir);
  set_log_level(fresh.log.level);
  if (scheduler_) {
    scheduler_->set_queue_depth(fresh.workers.queue_depth);
    scheduler_->set_memory_budget(effective_memory_budget(fresh.workers));
  }
  if (jobs_)
    jobs_->set_limits(fresh.sequences.max_queued, fresh.sequences.history, effective_memory_budget(fresh.workers));
  if (server_) {
    server_->set_connection_limits(connection_limits(fresh.server));
    server_->set_body_budget(effective_memory_budget(fresh.workers));
  }
  {
    std::lock_guard lock(config_mu_);
    config_ = std::make_shared<const Config>(std::move(fresh));
  }
  ++metrics_.reloads;
  spdlog::info("configuration reloaded from {}", config()->source.string());
}

void Service::shutdown() {
  if (shutting_down_.exchange(true)) return;
  const auto cfg = config();
  if (server_) server_->stop_accepting();
  spdlog::info("shutting down: draining in-flight requests (up to {} s)", cfg->server.drain_timeout_s);
  // Sequence jobs are cancelled, not drained: they may run for hours; run_sequence removes
  // what a stopped job wrote, so no half-written sequence is left in the dump directory.
  if (jobs_) jobs_->shutdown();
  if (scheduler_) scheduler_->drain_and_stop(std::chrono::duration<double>(cfg->server.drain_timeout_s));
  if (server_) server_->stop();
  server_.reset();
  jobs_.reset();
  scheduler_.reset();
  spdlog::info("stopped");
}

std::string Service::socket_description() const {
  std::string s;
  for (const auto& d : listener_descriptions_) s += (s.empty() ? "" : ", ") + d;
  return s;
}

}  // namespace hdrd::daemon

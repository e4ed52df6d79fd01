// The daemon as a whole: listeners, the HTTP transport, the scheduler with its render
// workers, the endpoint table, configuration snapshots (SIGHUP swaps them) and the
// orderly shutdown (SIGTERM: stop accepting, drain in-flight requests, stop).
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/config.hpp"
#include "daemon/jobs/dump_dir.hpp"
#include "daemon/http/server.hpp"
#include "daemon/jobs/jobs.hpp"
#include "daemon/metrics.hpp"
#include "daemon/jobs/scheduler.hpp"
#include "job/settings.hpp"

namespace hdrd::daemon {

class Service final : public HttpHandler {
 public:
  explicit Service(Config config);
  ~Service() override;
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  // Binds (or inherits) the sockets, starts the render workers and the HTTP server.
  // Throws HdrdError when a socket cannot be bound or MHD refuses to start.
  void start();
  // Applies what can change at run time (limits, roots, render defaults, log level,
  // queue depth, memory budget, connection caps and deadlines, access log); names what
  // needs a restart in the log. Throws (and changes nothing) when the new dump directory
  // cannot be written.
  void reload(Config fresh);
  // Stops accepting, drains in-flight requests within server.drain_timeout_s, stops.
  void shutdown();

  // Where the Unix socket is (empty when only inherited/TCP sockets are used).
  std::string socket_description() const;
  nlohmann::json status_json() const;

  // HttpHandler
  std::variant<std::size_t, Reply> begin(const HttpRequest& request) noexcept override;
  void handle(HttpRequest& request, std::shared_ptr<Responder> responder) noexcept override;
  void finished(const HttpRequest& request, const Reply& reply, std::size_t body_bytes) noexcept override;
  void connection_opened(bool tcp, const std::optional<PeerCred>& peer) noexcept override;

  struct Route;

 private:
  std::shared_ptr<const Config> config() const;
  const Route* find_route(const HttpRequest& r, std::string* allow) const;

  void get_status(HttpRequest&, std::shared_ptr<Responder>);
  void get_capabilities(HttpRequest&, std::shared_ptr<Responder>);
  void get_displays(HttpRequest&, std::shared_ptr<Responder>);
  void get_metrics(HttpRequest&, std::shared_ptr<Responder>);
  void post_render(HttpRequest&, std::shared_ptr<Responder>);
  void post_encode(HttpRequest&, std::shared_ptr<Responder>);
  void post_pattern(HttpRequest&, std::shared_ptr<Responder>);
  // The three as one: the frame job's transport (api_frame.cpp).
  void post_frame(job::Source source, HttpRequest&, std::shared_ptr<Responder>);
  void post_selftest(HttpRequest&, std::shared_ptr<Responder>);  // api_selftest.cpp
  // Sequences and their jobs (api_sequences.cpp, jobs.hpp).
  void post_sequences(HttpRequest&, std::shared_ptr<Responder>);
  void get_jobs(HttpRequest&, std::shared_ptr<Responder>);
  void get_job(HttpRequest&, std::shared_ptr<Responder>);     // /v1/jobs/{id}[/result|/sidecar]
  void delete_job(HttpRequest&, std::shared_ptr<Responder>);
  // Sequence plans submitted to a Slurm cluster (api_cluster.cpp, slurm.hpp, docs/cluster.md).
  void post_cluster_submission(HttpRequest&, std::shared_ptr<Responder>);
  void get_cluster_submission(HttpRequest&, std::shared_ptr<Responder>);     // /v1/cluster/submissions/{id}
  void delete_cluster_submission(HttpRequest&, std::shared_ptr<Responder>);
  struct ClusterState;
  static std::shared_ptr<ClusterState> new_cluster_state();  // api/cluster.cpp
  std::pair<std::size_t, std::size_t> cluster_kept() const;  // submissions remembered, their bytes
  std::shared_ptr<ClusterState> cluster_;
  // GET /v1/capabilities' "patterns": names, descriptions, sources, parameters, modes.
  static nlohmann::json pattern_capabilities();
  // Admits a job and connects its reply, cancellation and deadline to the responder.
  void submit(JobSpec spec, bool needs_renderer, const std::shared_ptr<Responder>& responder);

  static const std::vector<Route>& routes();

  mutable std::mutex config_mu_;
  std::shared_ptr<const Config> config_;
  std::string token_;
  Metrics metrics_;
  std::unique_ptr<DumpDirectory> dump_dir_;  // locked while used; stale temporaries removed at start
  std::unique_ptr<Scheduler> scheduler_;
  std::unique_ptr<JobRegistry> jobs_;
  std::unique_ptr<HttpServer> server_;
  std::vector<std::string> listener_descriptions_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::atomic<bool> shutting_down_{false};
};

// Sets spdlog's level from a name ("info", "debug", ...).
void set_log_level(const std::string& level);

}  // namespace hdrd::daemon

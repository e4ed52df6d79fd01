#include "daemon/metrics.hpp"

#include <fmt/format.h>

#include "daemon/http/server.hpp"
#include "daemon/jobs/scheduler.hpp"

namespace hdrd::daemon {

void Metrics::Histogram::observe(double v) {
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (v <= kBuckets[i]) ++counts[i];
  ++count;
  sum += v;
}

void Metrics::request_finished(const std::string& endpoint, unsigned status, double seconds, std::uint64_t bytes_in,
                               std::uint64_t bytes_out) {
  std::lock_guard lock(mu_);
  ++requests_[{endpoint, status}];
  latency_[endpoint].observe(seconds);
  bytes_in_ += bytes_in;
  bytes_out_ += bytes_out;
}

void Metrics::stage_time(const std::string& stage, double seconds) {
  std::lock_guard lock(mu_);
  stages_[stage].observe(seconds);
}

namespace {

void histogram_text(std::string& out, const std::string& name, const std::string& label, const std::string& value,
                    const std::array<std::uint64_t, Metrics::kBuckets.size()>& counts, std::uint64_t count,
                    double sum) {
  for (std::size_t i = 0; i < Metrics::kBuckets.size(); ++i)
    out += fmt::format("{}_bucket{{{}=\"{}\",le=\"{}\"}} {}\n", name, label, value, Metrics::kBuckets[i], counts[i]);
  out += fmt::format("{}_bucket{{{}=\"{}\",le=\"+Inf\"}} {}\n", name, label, value, count);
  out += fmt::format("{}_sum{{{}=\"{}\"}} {}\n", name, label, value, sum);
  out += fmt::format("{}_count{{{}=\"{}\"}} {}\n", name, label, value, count);
}

}  // namespace

std::string Metrics::prometheus_text(const std::map<std::string, double>& gauges) const {
  std::string out;
  std::lock_guard lock(mu_);
  out += "# HELP hdrd_requests_total HTTP requests handled, by endpoint and status.\n";
  out += "# TYPE hdrd_requests_total counter\n";
  for (const auto& [key, n] : requests_)
    out += fmt::format("hdrd_requests_total{{endpoint=\"{}\",status=\"{}\"}} {}\n", std::get<0>(key), std::get<1>(key), n);
  out += "# HELP hdrd_request_duration_seconds Time from the complete request to the response, by endpoint.\n";
  out += "# TYPE hdrd_request_duration_seconds histogram\n";
  for (const auto& [ep, h] : latency_)
    histogram_text(out, "hdrd_request_duration_seconds", "endpoint", ep, h.counts, h.count, h.sum);
  out += "# HELP hdrd_stage_duration_seconds Time spent in each stage of a job (render, encode, serialize).\n";
  out += "# TYPE hdrd_stage_duration_seconds histogram\n";
  for (const auto& [st, h] : stages_)
    histogram_text(out, "hdrd_stage_duration_seconds", "stage", st, h.counts, h.count, h.sum);
  auto counter = [&](const char* name, const char* help, std::uint64_t v) {
    out += fmt::format("# HELP {} {}\n# TYPE {} counter\n{} {}\n", name, help, name, name, v);
  };
  counter("hdrd_request_bytes_total", "Request body bytes received.", bytes_in_);
  counter("hdrd_response_bytes_total", "Response body bytes sent.", bytes_out_);
  counter("hdrd_coalesced_total", "Requests served by an identical job already in flight.", coalesced.load());
  counter("hdrd_cancelled_total", "Requests cancelled because the client disconnected.", cancelled.load());
  counter("hdrd_timeouts_total", "Requests that exceeded their time limit.", timed_out.load());
  counter("hdrd_rejected_queue_full_total", "Requests refused with 503 because the queue was full.",
          rejected_full.load());
  counter("hdrd_rejected_memory_total", "Requests refused with 503 because the memory budget was taken.",
          rejected_memory.load());
  counter("hdrd_connections_total", "Connections accepted.", connections.load());
  counter("hdrd_config_reloads_total", "Configuration reloads (SIGHUP) applied.", reloads.load());
  out += fmt::format("# HELP hdrd_in_flight_requests HTTP requests being handled.\n"
                     "# TYPE hdrd_in_flight_requests gauge\nhdrd_in_flight_requests {}\n", in_flight.load());
  for (const auto& [name, v] : gauges) out += fmt::format("# TYPE {} gauge\n{} {}\n", name, name, v);
  return out;
}

}  // namespace hdrd::daemon

namespace hdrd::daemon {

void add_resource_gauges(std::map<std::string, double>& gauges, const Scheduler* scheduler, const HttpServer* server) {
  if (scheduler) {
    const auto s = scheduler->stats();
    gauges["hdrd_memory_in_flight_bytes"] = double(s.memory_in_flight_bytes);
    gauges["hdrd_memory_budget_bytes"] = double(s.memory_budget_bytes);
  }
  if (server) {
    const auto c = server->connection_stats();
    gauges["hdrd_connections_open"] = c.open;
    gauges["hdrd_connections_evicted"] = double(c.evicted);
    gauges["hdrd_connections_header_timeouts"] = double(c.header_timeouts);
    gauges["hdrd_connections_body_timeouts"] = double(c.body_timeouts);
    gauges["hdrd_connections_refused"] = double(c.refused);
    gauges["hdrd_connections_hung_up"] = double(c.hung_up);
  }
}

}  // namespace hdrd::daemon

// Counters and latency histograms for GET /metrics (Prometheus text exposition format
// 0.0.4). Thread-safe; the hot path takes one short mutex per finished request.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>

namespace hdrd::daemon {

class Scheduler;
class HttpServer;

class Metrics {
 public:
  // Latency buckets in seconds (upper bounds; +Inf implied).
  static constexpr std::array<double, 12> kBuckets = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                                      0.1,   0.25,   0.5,   1.0,  2.5,   10.0};

  void request_finished(const std::string& endpoint, unsigned status, double seconds, std::uint64_t bytes_in,
                        std::uint64_t bytes_out);
  void stage_time(const std::string& stage, double seconds);  // "render", "encode", "serialize"

  std::atomic<std::int64_t> in_flight{0};        // HTTP requests being handled
  std::atomic<std::uint64_t> coalesced{0};       // requests that joined an identical job
  std::atomic<std::uint64_t> cancelled{0};       // requests whose client went away
  std::atomic<std::uint64_t> timed_out{0};       // requests past their time limit
  std::atomic<std::uint64_t> rejected_full{0};   // 503 queue.full
  std::atomic<std::uint64_t> rejected_memory{0}; // 503 queue.memory
  std::atomic<std::uint64_t> connections{0};     // connections accepted
  std::atomic<std::uint64_t> reloads{0};         // SIGHUP reloads applied

  // Prometheus text; `gauges` are appended as given (name -> value), e.g. queue depth.
  std::string prometheus_text(const std::map<std::string, double>& gauges) const;

 private:
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> counts{};
    std::uint64_t count = 0;
    double sum = 0;
    void observe(double v);
  };
  mutable std::mutex mu_;
  std::map<std::tuple<std::string, unsigned>, std::uint64_t> requests_;  // (endpoint, status)
  std::map<std::string, Histogram> latency_;                              // endpoint
  std::map<std::string, Histogram> stages_;                               // stage
  std::uint64_t bytes_in_ = 0, bytes_out_ = 0;
};

// Gauges and counters of what bounds the daemon: memory admitted against its budget, and
// the connection table (open, evicted, closed for slow headers or bodies, refused).
void add_resource_gauges(std::map<std::string, double>& gauges, const Scheduler* scheduler, const HttpServer* server);

}  // namespace hdrd::daemon

// Scheduling (issue: "Scheduling"): a bounded admission queue; N render workers, each
// owning a resource created on its own thread (a renderer with its GL context, which is
// bound to that thread); a CPU pool for encoding; identical concurrent requests share one
// job (coalesced by key); a waiter whose client left is detached, and a job nobody waits
// for any more is cancelled at its next stage boundary. Admission also weighs memory: each
// job carries an estimate of what it will allocate (memory.hpp), and the jobs admitted
// together stay within a budget; one more is refused (503 queue.memory) rather than let
// the resident set grow without bound. Once the daemon has been idle for a moment after a
// large job, the allocator's free memory is handed back to the system (malloc_trim), so
// that a burst does not leave it resident; back-to-back jobs reuse it instead of faulting
// fresh pages in for every frame.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/http/reply.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon {

using Clock = std::chrono::steady_clock;

// What a stage may look at while it runs: whether to give up early.
class JobControl {
 public:
  JobControl(const std::atomic<bool>& cancelled, Clock::time_point deadline) : cancelled_(cancelled), deadline_(deadline) {}
  bool cancelled() const { return cancelled_.load(std::memory_order_relaxed); }
  bool expired() const { return Clock::now() > deadline_; }
  bool should_stop() const { return cancelled() || expired(); }
  Clock::time_point deadline() const { return deadline_; }

 private:
  const std::atomic<bool>& cancelled_;
  Clock::time_point deadline_;
};

// A render worker's thread-bound resource (the renderer and its GL context).
class RenderResource {
 public:
  virtual ~RenderResource() = default;
  virtual nlohmann::json info() const = 0;  // backend, GL_RENDERER, ...
  // After a job whose estimate reached SchedulerOptions::trim_after_bytes, on the worker's
  // thread: give back what the resource keeps for the next job (a large frame's targets).
  virtual void release_large_buffers(std::uint64_t /*job_memory_bytes*/) {}
};
using RenderResourceFactory = std::function<Result<std::unique_ptr<RenderResource>>(int worker_index)>;

// `seconds` after `start`, saturating: a configured 1e300 s must not overflow into the past.
Clock::time_point deadline_after(Clock::time_point start, double seconds);

struct JobSpec {
  std::string key;              // coalescing key; empty: never shared
  Clock::time_point deadline;
  std::uint64_t memory_bytes = 0;  // estimated peak allocation of the job (memory.hpp)
  // Runs on a render worker when set (the resource is null when the worker has none).
  std::function<Result<void>(RenderResource*, const JobControl&)> render;
  // Runs on the encode pool; produces the reply every waiter receives.
  std::function<Reply(const JobControl&)> finish;
};

struct Job;

// One request waiting for a job. `deliver` is called exactly once: with the job's reply,
// or never if the waiter was cancelled first (cancel() returns true then).
struct Waiter {
  std::function<void(std::shared_ptr<const Reply>, bool coalesced)> deliver;
  std::atomic<bool> done{false};
  bool coalesced = false;
  std::weak_ptr<Job> job;
};

struct SchedulerOptions {
  int render_workers = 1;
  int encode_threads = 2;
  int queue_depth = 16;         // admitted jobs beyond those the workers can run at once
  bool coalesce = true;
  std::uint64_t memory_budget_bytes = std::uint64_t(4) << 30;  // admitted jobs' estimates together
  // Jobs whose estimate is at least this return the allocator's free memory afterwards,
  // once no job has run for trim_idle (so that the jobs of a burst reuse it).
  std::uint64_t trim_after_bytes = std::uint64_t(32) << 20;
  std::chrono::milliseconds trim_idle{2000};
};

struct SchedulerStats {
  int admitted = 0;             // jobs admitted and not finished
  int queued = 0;               // jobs not yet started by any worker
  int running = 0;
  int render_workers = 0, render_workers_ready = 0, encode_threads = 0, capacity = 0;
  std::uint64_t memory_in_flight_bytes = 0, memory_budget_bytes = 0;
  std::uint64_t trims = 0;      // times the allocator's free memory was handed back (trim_loop)
  nlohmann::json workers = nlohmann::json::array();  // per render worker: info or error
};

class Scheduler {
 public:
  Scheduler(SchedulerOptions options, RenderResourceFactory factory);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  // Starts the threads and waits until every render worker has created its resource.
  void start();

  // Admits a job (or joins an identical one in flight). Errors: queue.full, queue.memory
  // (the budget is taken by admitted jobs), request.memory (the job alone exceeds the
  // budget), server.draining, renderer.unavailable (a render job and no worker has one).
  Result<std::shared_ptr<Waiter>> submit(JobSpec spec, std::function<void(std::shared_ptr<const Reply>, bool)> deliver,
                                         bool needs_renderer);

  // Detaches a waiter whose client left or whose time ran out. Returns false when the
  // reply was already delivered (or is being delivered).
  bool cancel(const std::shared_ptr<Waiter>& waiter);

  // Stops admitting; waits up to `timeout` for admitted jobs to finish; then cancels the
  // rest (their waiters get server.draining) and joins every thread.
  void drain_and_stop(std::chrono::duration<double> timeout);

  void set_queue_depth(int depth);
  void set_memory_budget(std::uint64_t bytes);
  SchedulerStats stats() const;
  bool renderer_available() const;

 private:
  void render_loop(int index);
  void encode_loop();
  void finish_job(const std::shared_ptr<Job>& job, std::shared_ptr<const Reply> reply);
  std::shared_ptr<Job> pop(std::deque<std::shared_ptr<Job>>& q, std::condition_variable& cv);

  SchedulerOptions options_;
  RenderResourceFactory factory_;
  mutable std::mutex mu_;
  std::condition_variable render_cv_, encode_cv_, idle_cv_, ready_cv_, trim_cv_;
  // The idle trim: when a large job finished last (unset: nothing to give back).
  std::optional<Clock::time_point> trim_due_;
  std::uint64_t trims_ = 0;
  void trim_loop();
  std::deque<std::shared_ptr<Job>> render_queue_, encode_queue_;
  std::shared_ptr<const Reply> cancelled_reply() const;

  std::unordered_map<std::string, std::shared_ptr<Job>> by_key_;
  std::unordered_set<std::shared_ptr<Job>> active_;  // admitted and not finished
  int running_ = 0, started_workers_ = 0, ready_workers_ = 0;
  std::uint64_t memory_in_flight_ = 0;
  void release_memory(Job& job);  // under mu_
  bool stopping_ = false;
  std::atomic<bool> draining_{false};
  std::vector<nlohmann::json> worker_info_;
  std::vector<std::thread> threads_;
};

}  // namespace hdrd::daemon

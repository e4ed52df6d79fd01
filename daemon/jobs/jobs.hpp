// The daemon's sequence jobs (POST /v1/sequences, GET/DELETE /v1/jobs/{id}; docs/api.md
// "Sequences and jobs"). A sequence runs for seconds to hours, so its request is answered
// 202 at once and the job lives here: a bounded queue, `max_running` threads of its own
// (each with its own renderer, made on that thread with the daemon's backend, so a job
// survives its client's disconnect and never holds up the single-frame workers), and a
// bounded history of finished jobs. Admission weighs memory like the scheduler's: each job
// carries its estimate (memory.hpp), the admitted sequences together stay within the budget,
// with what the finished jobs keep (their records: a job's request is dropped when it ends).
// Results are written by job::run_sequence into the dump directory, all or nothing; a
// cancelled or failed job leaves no file.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"
#include "job/request.hpp"
#include "job/sequence.hpp"

namespace hdrd::daemon {

enum class JobState { queued, running, done, failed, cancelled };
std::string_view to_string(JobState s);
inline bool is_final(JobState s) { return s == JobState::done || s == JobState::failed || s == JobState::cancelled; }

// What a submission carries: the parsed sequence request and where its files go.
struct SequenceSpec {
  job::FrameRequest request;
  std::filesystem::path outbase;       // dump_dir / name
  std::string name;
  int frames_total = 0;
  std::uint64_t memory_bytes = 0;      // estimate_sequence_memory
  job::JobOptions options;             // threads, scene confinement
  std::optional<double> timeout_s;     // the request's own time limit, from when it starts
};

// A job as GET /v1/jobs/{id} reports it (a copy; the job goes on).
struct JobInfo {
  std::string id, name, source;
  JobState state = JobState::queued;
  int frames_done = 0, frames_total = 0;
  double fps = 0, eta_s = 0;
  std::optional<Error> error;                  // failed (and cancelled: why)
  std::map<std::string, std::string> files;    // done: kind -> path (job/sequence.hpp SequenceResult::files)
  // done: kind -> the file the job wrote (device, inode, size), for every file but the
  // per-frame patterns: GET .../result and .../sidecar serve only that file (else 410).
  std::map<std::string, io::FileIdentity> identities;
  std::chrono::system_clock::time_point created;
  std::optional<std::chrono::system_clock::time_point> started, finished;
  std::uint64_t memory_bytes = 0;
  bool files_removed = false;                  // DELETE of a finished job
  std::string superseded_by;                   // a later job of the same name overwrote the files
  nlohmann::json to_json() const;              // with links
};

struct JobRegistryOptions {
  int max_running = 1;
  int max_queued = 16;
  int history = 100;
  std::uint64_t memory_budget_bytes = std::uint64_t(4) << 30;
  std::string backend = "auto";                // shading::parse_backend names
  std::size_t queue_depth = 2;                 // job::SequenceOptions::queue_depth
};

class JobRegistry {
 public:
  explicit JobRegistry(JobRegistryOptions options);
  ~JobRegistry();  // shutdown()
  JobRegistry(const JobRegistry&) = delete;
  JobRegistry& operator=(const JobRegistry&) = delete;

  // Admits a job. Errors: server.draining, queue.full, request.memory (the job alone
  // exceeds the budget), queue.memory (the budget is taken), job.conflict (a queued or
  // running job writes the same name).
  Result<JobInfo> submit(SequenceSpec spec);
  std::optional<JobInfo> get(std::string_view id) const;
  std::vector<JobInfo> list() const;  // newest first

  // DELETE /v1/jobs/{id}: a queued job is cancelled at once, a running one is stopped at its
  // next frame (run_sequence removes what it wrote) and `done` is called when it has; a
  // finished job's files are removed. `done` gets the job's final state, or nullopt for an
  // unknown id; it may run on a job thread.
  void remove(std::string_view id, std::function<void(std::optional<Result<JobInfo>>)> done);

  // Stops admitting, cancels every job (running ones stop at their next frame and remove
  // their files) and joins the threads.
  void shutdown();
  // [sequences] max_queued, history and the budget change at run time; max_running does not.
  void set_limits(int max_queued, int history, std::uint64_t memory_budget_bytes);

  struct Stats {
    int queued = 0, running = 0, finished = 0;
    std::uint64_t memory_in_flight_bytes = 0;
    // What the finished jobs of the history hold: their records, never their requests
    // (dropped when a job ends). Counted in the budget with what is in flight.
    std::uint64_t memory_kept_bytes = 0;
  };
  Stats stats() const;

 private:
  struct Job;
  void worker_loop();
  void run(const std::shared_ptr<Job>& self, std::unique_ptr<shading::Renderer>& renderer);
  void finish(const std::shared_ptr<Job>& job, JobState state, std::optional<Error> error);  // under no lock
  void trim_history();  // under mu_
  static JobInfo info_of(const Job& job);  // under mu_
  static std::uint64_t kept_bytes(const Job& job);  // what a final job holds (Stats::memory_kept_bytes)
  std::uint64_t kept_bytes_locked() const;           // over the history, under mu_

  JobRegistryOptions options_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::map<std::string, std::shared_ptr<Job>, std::less<>> jobs_;
  std::vector<std::shared_ptr<Job>> order_;  // oldest first
  std::uint64_t memory_in_flight_ = 0;
  int running_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

// Removes every file of a finished sequence: its video, sidecar, metadata files and the
// per-frame dumps its `frames.*` patterns name for `frames` frames.
void remove_sequence_files(const std::map<std::string, std::string>& files, int frames);

}  // namespace hdrd::daemon

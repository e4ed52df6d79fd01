// A small Slurm client: submits an `hdrd sequence plan` to a configured Slurm cluster (the
// shards' job array and the merge job that waits for it, deploy/slurm/) and reports the
// progress of those jobs (docs/cluster.md). It runs sbatch, squeue, sacct and scancel as
// subprocesses (argv arrays, no shell, timeouts, bounded output: daemon/cluster/subprocess.hpp)
// and parses their machine-readable output (--parsable, fixed -o formats) strictly.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon::slurm {

// What a job or array task is doing, from Slurm's two dozen states (see map_state).
enum class JobState { pending, running, completed, failed, cancelled };
std::string_view to_string(JobState s);

// One job, or one task of a job array, as squeue or sacct reports it.
struct TaskStatus {
  std::uint64_t job_id = 0;                 // the array job's id for an array task
  std::optional<std::uint32_t> array_task;  // the task index; nullopt for a plain job
  JobState state = JobState::pending;
  std::string slurm_state;                  // Slurm's name, e.g. "NODE_FAIL" ("CANCELLED by 0" -> "CANCELLED")
  std::string reason;                       // squeue's reason, e.g. "Dependency", "DependencyNeverSatisfied"
  std::string exit_code;                    // sacct's "status:signal", e.g. "0:0", "3:0"; empty from squeue
};

// Slurm's state names (squeue %T, sacct State: slurm/src/common/slurm_protocol_defs.c
// job_state_string) onto the five above. Unknown names are errors ("slurm.state").
Result<JobState> map_state(std::string_view slurm_state);

// --- Parsers (strict: anything off the documented shape is an error naming line and field) ---

// `sbatch --parsable`: "ID" or "ID;CLUSTER", one line. Errors "slurm.sbatch_output".
Result<std::uint64_t> parse_sbatch_parsable(std::string_view out);

// `squeue --noheader --array --states=all --format=` kSqueueFormat: one line per job or
// array task, "ARRAY_JOB_ID|TASK|STATE|REASON" (TASK "N/A" for a plain job; a range such as
// "2-5%2" or "[1,3-4]" for tasks not yet split off, expanded here). More than max_rows rows
// (the caller knows how many jobs it asked about) is an error, so a short range cannot
// become millions of rows. Errors "slurm.squeue_output".
inline constexpr std::string_view kSqueueFormat = "%F|%K|%T|%r";
inline constexpr std::size_t kMaxRows = 100000;
Result<std::vector<TaskStatus>> parse_squeue(std::string_view out, std::size_t max_rows = kMaxRows);

// `sacct --noheader --parsable2 --allocations --format=` kSacctFormat: "JOBID|STATE|EXITCODE"
// with JOBID "123", "123_4" or "123_[5-7%2]"; max_rows as for squeue. Errors "slurm.sacct_output".
inline constexpr std::string_view kSacctFormat = "JobID,State,ExitCode";
Result<std::vector<TaskStatus>> parse_sacct(std::string_view out, std::size_t max_rows = kMaxRows);

// The header of an `hdrd sequence plan` file (the fields every engine needs; the same rules
// as deploy/lib/plan.sh, tested on the same cases). Errors "plan.*" with the field.
struct PlanHeader {
  std::uint32_t shards = 0;
  std::uint64_t frames = 0;
  std::filesystem::path work_dir;  // absolute: a relative one is taken relative to the plan's folder
};
inline constexpr std::uint32_t kMaxShards = 1000000;
Result<PlanHeader> parse_plan_header(std::string_view json, const std::filesystem::path& plan_folder);
// The plan file opened through `files` (encode/io/beneath.hpp): beneath the asset root for
// the daemon (no links, no FIFO, no hard link), as given for the CLI.
Result<PlanHeader> read_plan_header(const std::filesystem::path& plan_path, const io::InputFiles& files = {});

// --- The client ---------------------------------------------------------------------------

struct ClusterConfig {
  std::filesystem::path scripts_dir;        // deploy/slurm: shard.sbatch, merge.sbatch (required)
  std::filesystem::path slurm_bin_dir;      // where sbatch, squeue, sacct, scancel are; empty: PATH
  std::filesystem::path slurm_conf;         // SLURM_CONF for them; empty: their default
  std::string hdrd_program = "hdrd";        // hdrd as the compute nodes see it
  std::vector<std::string> sbatch_options;  // given to both sbatch calls after ours (--partition=...)
  std::chrono::milliseconds command_timeout{30000};
  std::size_t max_output_bytes = std::size_t(8) << 20;
};

struct SubmitOptions {
  std::vector<std::uint32_t> shards;        // empty: all of the plan's; else only these (retries)
  std::optional<std::uint32_t> max_parallel;  // at most this many shards at once (--array=...%K)
};

// Shard indices as ascending runs of consecutive ones: what a submission keeps, so that a
// 1e6-shard plan is one run of 8 bytes, not a 4 MB list (issue 28.10).
class ShardRanges {
 public:
  ShardRanges() = default;
  static ShardRanges all(std::uint32_t shards);                          // 0 .. shards-1
  static ShardRanges of(std::vector<std::uint32_t> indices);             // any order, repeats dropped
  std::size_t size() const { return size_; }                             // how many indices
  std::uint32_t at(std::size_t k) const;                                 // the k-th, ascending (k < size())
  std::optional<std::size_t> position(std::uint32_t shard) const;        // k with at(k) == shard
  std::uint32_t last() const { return runs_.empty() ? 0 : runs_.back().second; }
  std::string spec() const;                                              // Slurm's --array syntax: "0-2", "1,4-6"
  std::size_t kept_bytes() const { return sizeof *this + runs_.capacity() * sizeof runs_[0]; }

 private:
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs_;  // [first, last], ascending, apart
  std::vector<std::size_t> before_;                            // indices in the runs before each
  std::size_t size_ = 0;
  void add(std::uint32_t first, std::uint32_t last);
};

struct Submission {
  std::uint64_t array_job_id = 0;
  std::uint64_t merge_job_id = 0;
  ShardRanges shards;                       // the submitted shard indices
};

struct Progress {
  std::vector<TaskStatus> shards;           // one per submitted shard Slurm still knows, by index
  std::vector<std::uint32_t> unknown_shards;  // neither squeue nor sacct knows them (aged out, no accounting)
  std::optional<TaskStatus> merge;          // nullopt when Slurm no longer knows it
  std::uint32_t pending = 0, running = 0, completed = 0, failed = 0, cancelled = 0;  // over shards
  // completed: the merge completed. failed: a shard or the merge failed. cancelled: the
  // merge was cancelled (by a user, or because a shard never succeeded) and nothing failed.
  // running: a shard or the merge runs. pending: otherwise.
  JobState state = JobState::pending;
};

// The two sbatch command lines of a submission (argv, without the program's directory);
// the merge's depends on the array job, given as array_job_id. deploy/slurm/submit.sh
// builds the same (a test holds them equal).
struct SbatchCommands {
  std::vector<std::string> array, merge;
};
SbatchCommands sbatch_commands(const ClusterConfig& config, const std::filesystem::path& plan_path,
                               const PlanHeader& plan, const std::filesystem::path& outbase,
                               const SubmitOptions& options, std::uint64_t array_job_id);

class Client {
 public:
  explicit Client(ClusterConfig config);  // throws HdrdError when scripts_dir lacks the scripts

  // Reads the plan, submits the array and the merge job (a merge that cannot be submitted
  // cancels the array). Errors: plan.*, slurm.options, slurm.sbatch (with sbatch's message),
  // slurm.sbatch_output, process.*.
  Result<Submission> submit(const std::filesystem::path& plan_path, const std::filesystem::path& outbase,
                            const SubmitOptions& options = {},
                            const io::InputFiles& files = {}) const;
  // squeue for the jobs it still knows, sacct for those it has forgotten.
  Result<Progress> progress(const Submission& submission) const;
  // scancel of the merge and the array (their pending and running parts).
  Result<void> cancel(const Submission& submission) const;

 private:
  struct Output;
  Result<Output> run(const std::string& program, std::vector<std::string> args) const;
  ClusterConfig config_;
};

}  // namespace hdrd::daemon::slurm

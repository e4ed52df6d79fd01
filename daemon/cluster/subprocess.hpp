// Runs a program as a child process and collects what it prints: argv arrays (no shell),
// stdin from /dev/null, only fds 0-2 inherited, a wall-clock timeout and a bound on the
// output. Used by the Slurm client (daemon/cluster/slurm.hpp) for sbatch, squeue, sacct, scancel.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::daemon {

struct ProcessSpec {
  std::vector<std::string> argv;  // argv[0] without a '/' is looked up on PATH
  std::vector<std::pair<std::string, std::string>> env;  // set (or replaced) in the inherited environment
  std::chrono::milliseconds timeout{30000};
  std::size_t max_output_bytes = std::size_t(1) << 20;  // stdout and stderr, each
};

struct ProcessResult {
  int exit_code = -1;    // the exit status; -1 when a signal ended it
  int signal = 0;        // the signal that ended it, or 0
  std::string out, err;  // what it wrote on stdout and stderr
};

// The child runs in its own process group. Errors: "process.spawn" (the program is missing
// or cannot run), "process.timeout" and "process.output_too_large" (the child's process
// group, what it started included, is killed with SIGKILL and the child reaped first). A program
// that runs and fails is not an error here: look at exit_code.
Result<ProcessResult> run_process(const ProcessSpec& spec);

}  // namespace hdrd::daemon

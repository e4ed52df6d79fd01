#include "daemon/cluster/subprocess.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <string_view>
#include <thread>

extern char** environ;

namespace hdrd::daemon {
namespace {

using Clock = std::chrono::steady_clock;

// Owns a file descriptor.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Fd& operator=(Fd&& o) noexcept {
    reset(std::exchange(o.fd_, -1));
    return *this;
  }
  ~Fd() { reset(); }
  int get() const { return fd_; }
  void reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_ = -1;
};

std::string program_name(const ProcessSpec& spec) { return spec.argv.empty() ? std::string("(none)") : spec.argv[0]; }

// The inherited environment with spec.env set on top, as "K=V" strings.
std::vector<std::string> child_environment(const ProcessSpec& spec) {
  std::vector<std::string> env;
  for (char** e = environ; e && *e; ++e) {
    const std::string_view kv(*e);
    bool replaced = false;
    for (const auto& [k, v] : spec.env)
      if (kv.size() > k.size() && kv.substr(0, k.size()) == k && kv[k.size()] == '=') replaced = true;
    if (!replaced) env.emplace_back(kv);
  }
  for (const auto& [k, v] : spec.env) env.push_back(k + "=" + v);
  return env;
}

std::vector<char*> pointers(std::vector<std::string>& strings) {
  std::vector<char*> p;
  for (auto& s : strings) p.push_back(s.data());
  p.push_back(nullptr);
  return p;
}

// Starts the child with stdout/stderr on the write ends of two pipes; returns its pid.
Result<pid_t> spawn(const ProcessSpec& spec, int out_w, int err_w) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&fa, out_w, 1);
  posix_spawn_file_actions_adddup2(&fa, err_w, 2);
  posix_spawn_file_actions_addclosefrom_np(&fa, 3);  // nothing else of the daemon's leaks in
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // The child starts with default signal dispositions and an empty mask, whatever the
  // daemon blocks or ignores (SIGPIPE, the signals its threads wait for).
  sigset_t all, none;
  sigfillset(&all);
  sigemptyset(&none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setsigmask(&attr, &none);
  // Its own process group (pgid = its pid), so that a timeout stops what it started too.
  posix_spawnattr_setpgroup(&attr, 0);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETPGROUP);
  std::vector<std::string> argv_s(spec.argv.begin(), spec.argv.end());
  std::vector<std::string> env_s = child_environment(spec);
  auto argv = pointers(argv_s);
  auto envp = pointers(env_s);
  pid_t pid = -1;
  const int rc = ::posix_spawnp(&pid, argv[0], &fa, &attr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&attr);
  if (rc != 0)
    return make_error("process.spawn", "cannot run " + program_name(spec) + ": " + std::strerror(rc), "argv");
  return pid;
}

// Kills the child's whole process group (a Slurm wrapper's own children with it: issue
// 28.11), before reaping the child, whose pid is the group's id until then.
void kill_and_reap(pid_t pid) {
  ::kill(-pid, SIGKILL);
  ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

// Waits for the child until the deadline; false on timeout (the child is still running).
bool wait_until(pid_t pid, Clock::time_point deadline, int& status) {
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return true;
    if (r < 0 && errno != EINTR) return true;  // not our child any more: nothing to wait for
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

}  // namespace

Result<ProcessResult> run_process(const ProcessSpec& spec) {
  if (spec.argv.empty() || spec.argv[0].empty()) return make_error("process.spawn", "no program to run", "argv");
  std::array<int, 2> out_p{}, err_p{};
  if (::pipe2(out_p.data(), O_CLOEXEC) != 0)
    return make_error("process.spawn", std::string("pipe: ") + std::strerror(errno), "argv");
  Fd out_r(out_p[0]), out_w(out_p[1]);
  if (::pipe2(err_p.data(), O_CLOEXEC) != 0)
    return make_error("process.spawn", std::string("pipe: ") + std::strerror(errno), "argv");
  Fd err_r(err_p[0]), err_w(err_p[1]);
  auto pid = spawn(spec, out_w.get(), err_w.get());
  if (!pid) return pid.error();
  out_w.reset();
  err_w.reset();

  const auto deadline = Clock::now() + spec.timeout;
  ProcessResult r;
  std::array<pollfd, 2> fds{{{out_r.get(), POLLIN, 0}, {err_r.get(), POLLIN, 0}}};
  std::array<std::string*, 2> sinks{&r.out, &r.err};
  int open_pipes = 2;
  char buf[16384];
  while (open_pipes > 0) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) break;
    const int n = ::poll(fds.data(), fds.size(), int(std::min<long long>(left, 1000)));
    if (n < 0 && errno != EINTR) break;
    for (std::size_t i = 0; i < fds.size(); ++i) {
      if (fds[i].fd < 0 || !(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t got = ::read(fds[i].fd, buf, sizeof buf);
      if (got > 0) {
        sinks[i]->append(buf, std::size_t(got));
        if (sinks[i]->size() > spec.max_output_bytes) {
          kill_and_reap(*pid);
          return make_error("process.output_too_large",
                            program_name(spec) + " wrote more than " + std::to_string(spec.max_output_bytes) +
                                " bytes on " + (i == 0 ? "stdout" : "stderr") + "; stopped",
                            "argv");
        }
      } else if (got == 0 || (errno != EINTR && errno != EAGAIN)) {
        fds[i].fd = -1;
        --open_pipes;
      }
    }
  }
  int status = 0;
  if (open_pipes > 0 || !wait_until(*pid, deadline, status)) {
    kill_and_reap(*pid);
    return make_error("process.timeout",
                      program_name(spec) + " did not finish within " + std::to_string(spec.timeout.count()) +
                          " ms; stopped",
                      "argv");
  }
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

}  // namespace hdrd::daemon

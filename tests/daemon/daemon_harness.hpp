// Starts the real `hdrd serve` on a temporary socket for end-to-end tests, and stops it.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "clients/cpp/client.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::testing {

class DaemonProcess {
 public:
  // `extra_toml` is appended to a config with the socket, asset root and dump dir set.
  // `before_exec` runs in the child before exec (e.g. to pass a socket on fd 3).
  explicit DaemonProcess(const std::string& extra_toml = "", std::vector<std::string> extra_args = {},
                         std::function<void()> before_exec = {}, bool wait_ready = true)
      : socket_(dir_ / "hdrd.sock"), assets_(dir_ / "assets"), dumps_(dir_ / "dumps"), config_(dir_ / "hdrd.toml"),
        log_(dir_ / "daemon.log") {
    std::filesystem::create_directories(assets_);
    write_config(extra_toml);
    std::vector<std::string> args = {hdrd_binary().string(), "serve", "--config", config_.string()};
    for (auto& a : extra_args) args.push_back(a);
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      if (before_exec) before_exec();
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    if (wait_ready) ready_ = wait_until_ready();
  }

  ~DaemonProcess() { stop(SIGKILL); }

  // [server] comes last, so `extra_toml` may start with more [server] keys (before any
  // section header of its own).
  void write_config(const std::string& extra_toml) {
    std::ofstream(config_) << "[paths]\nasset_root = \"" << assets_.string() << "\"\ndump_dir = \"" << dumps_.string()
                           << "\"\n[log]\nlevel = \"info\"\n"
                           << "[server]\nsocket_path = \"" << socket_.string() << "\"\n"
                           << extra_toml;
  }

  bool wait_until_ready(std::chrono::seconds limit = std::chrono::seconds(60)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      if (!alive()) return false;
      daemon::Client c(options());
      auto r = c.request("GET", "/v1/status");
      if (r && r->status == 200) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

  bool alive() {
    if (pid_ <= 0) return false;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      exit_status_ = status;
      pid_ = -1;
      return false;
    }
    return true;
  }

  // Sends `sig` and waits for the exit; returns the exit code (-1 if killed by a signal).
  int stop(int sig = SIGTERM, std::chrono::seconds limit = std::chrono::seconds(60)) {
    if (pid_ > 0) {
      ::kill(pid_, sig);
      const auto end = std::chrono::steady_clock::now() + limit;
      while (alive() && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (pid_ > 0) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &exit_status_, 0);
        pid_ = -1;
      }
    }
    return WIFEXITED(exit_status_) ? WEXITSTATUS(exit_status_) : -1;
  }

  daemon::ClientOptions options(double timeout_s = 120) const {
    daemon::ClientOptions o;
    o.socket_path = socket_.string();
    o.timeout_s = timeout_s;
    return o;
  }
  daemon::Client client(double timeout_s = 120) const { return daemon::Client(options(timeout_s)); }

  pid_t pid() const { return pid_; }
  bool ready() const { return ready_; }
  const std::filesystem::path& socket() const { return socket_; }
  const std::filesystem::path& assets() const { return assets_; }
  const std::filesystem::path& dumps() const { return dumps_; }
  const std::filesystem::path& config() const { return config_; }
  const std::filesystem::path& dir() const { return dir_.path(); }
  std::string log() const { return read_file(log_); }

 private:
  TempDir dir_;
  std::filesystem::path socket_, assets_, dumps_, config_, log_;
  pid_t pid_ = -1;
  int exit_status_ = 0;
  bool ready_ = false;
};

// A raw connection for misbehaving-client tests (partial requests, slow writes, hang-ups).
class RawConnection {
 public:
  explicit RawConnection(const std::filesystem::path& socket) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", socket.c_str());
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~RawConnection() { close(); }
  bool connected() const { return connected_; }
  bool send(const std::string& s) { return ::send(fd_, s.data(), s.size(), MSG_NOSIGNAL) == ssize_t(s.size()); }
  void shutdown_write() { ::shutdown(fd_, SHUT_WR); }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Reads until `needle` arrived, the peer closed or `limit` passed; returns what arrived.
  std::string read_until(const std::string& needle, std::chrono::seconds limit) {
    std::string out;
    const auto end = std::chrono::steady_clock::now() + limit;
    char buf[4096];
    while (out.find(needle) == std::string::npos && std::chrono::steady_clock::now() < end) {
      timeval tv{0, 100000};
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0) break;
      if (n > 0) out.append(buf, std::size_t(n));
      else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) break;
    }
    return out;
  }
  // Reads until the peer closes or `limit` passes; returns what arrived and whether it closed.
  std::pair<std::string, bool> read_until_closed(std::chrono::seconds limit) {
    std::string out;
    const auto end = std::chrono::steady_clock::now() + limit;
    char buf[4096];
    while (std::chrono::steady_clock::now() < end) {
      timeval tv{0, 100000};
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0) return {out, true};
      if (n > 0) out.append(buf, std::size_t(n));
      else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return {out, true};
    }
    return {out, false};
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

}  // namespace hdrd::testing

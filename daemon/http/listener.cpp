#include "daemon/http/listener.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>

#include "encode/result.hpp"

namespace fs = std::filesystem;

namespace hdrd::daemon {
namespace {

[[noreturn]] void sys_fail(const std::string& what) {
  throw HdrdError(make_error("server.socket", fmt::format("{}: {}", what, std::strerror(errno)), "server.socket_path"));
}

bool socket_is_live(const sockaddr_un& addr) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const bool live = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return live;
}

}  // namespace

Listener::Listener(int fd, std::string description, bool is_unix, fs::path unlink_path)
    : fd_(fd), description_(std::move(description)), is_unix_(is_unix), unlink_path_(std::move(unlink_path)) {
  struct stat st{};
  if (!unlink_path_.empty() && ::lstat(unlink_path_.c_str(), &st) == 0) {
    unlink_dev_ = st.st_dev;
    unlink_ino_ = st.st_ino;
  } else {
    unlink_path_.clear();  // nothing of ours to remove
  }
}

Listener::~Listener() { close(); }

Listener& Listener::operator=(Listener&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    description_ = std::move(o.description_);
    is_unix_ = o.is_unix_;
    unlink_path_ = std::move(o.unlink_path_);
    unlink_dev_ = o.unlink_dev_;
    unlink_ino_ = o.unlink_ino_;
    o.fd_ = -1;
    o.unlink_path_.clear();
  }
  return *this;
}

int Listener::release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

void Listener::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!unlink_path_.empty()) {
    // Only the inode we bound: if another daemon has since replaced the socket file, the
    // path is its now. (A window remains between lstat and unlink; nothing narrower exists
    // for a path.)
    struct stat st{};
    if (::lstat(unlink_path_.c_str(), &st) == 0 && st.st_dev == unlink_dev_ && st.st_ino == unlink_ino_)
      ::unlink(unlink_path_.c_str());
    unlink_path_.clear();
  }
}

Listener listen_unix(const fs::path& path, unsigned mode, const std::string& group, int backlog) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string p = path.string();
  if (p.empty() || p.size() >= sizeof addr.sun_path)
    throw HdrdError(make_error("server.socket", fmt::format("socket path '{}' is empty or longer than {} bytes", p,
                                                            sizeof addr.sun_path - 1), "server.socket_path"));
  std::memcpy(addr.sun_path, p.c_str(), p.size() + 1);

  std::error_code ec;
  if (path.has_parent_path() && !fs::exists(path.parent_path(), ec)) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) throw HdrdError(make_error("server.socket", "cannot create " + path.parent_path().string() + ": " + ec.message(),
                                       "server.socket_path"));
    ::chmod(path.parent_path().c_str(), 0750);
  }
  struct stat st{};
  if (::lstat(p.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode))
      throw HdrdError(make_error("server.socket", p + " exists and is not a socket; refusing to replace it",
                                 "server.socket_path"));
    if (socket_is_live(addr))
      throw HdrdError(make_error("server.socket", p + " is in use by a running daemon", "server.socket_path"));
    ::unlink(p.c_str());  // stale socket from a previous run
  }

  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) sys_fail("socket(AF_UNIX)");
  // Bind under a umask that leaves no window in which others could connect.
  const mode_t old_mask = ::umask(0777 & ~mode);
  const int rc = ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int bind_errno = errno;
  ::umask(old_mask);
  if (rc != 0) {
    ::close(fd);
    errno = bind_errno;
    sys_fail("bind " + p);
  }
  Listener l(fd, "unix:" + p, true, path);
  if (::chmod(p.c_str(), mode) != 0) sys_fail("chmod " + p);
  if (!group.empty()) {
    const struct group* g = ::getgrnam(group.c_str());
    if (!g) throw HdrdError(make_error("server.socket", "unknown group '" + group + "'", "server.socket_group"));
    if (::chown(p.c_str(), uid_t(-1), g->gr_gid) != 0) sys_fail("chgrp " + p);
  }
  if (::listen(fd, backlog) != 0) sys_fail("listen " + p);
  return l;
}

Listener listen_tcp(const std::string& host_port, bool allow_non_loopback, int backlog) {
  std::string host, port;
  if (!host_port.empty() && host_port.front() == '[') {
    const auto close = host_port.find(']');
    if (close == std::string::npos || close + 1 >= host_port.size() || host_port[close + 1] != ':')
      throw HdrdError(make_error("server.tcp", "tcp_listen must be host:port or [v6]:port", "server.tcp_listen"));
    host = host_port.substr(1, close - 1);
    port = host_port.substr(close + 2);
  } else {
    const auto colon = host_port.rfind(':');
    if (colon == std::string::npos)
      throw HdrdError(make_error("server.tcp", "tcp_listen must be host:port or [v6]:port", "server.tcp_listen"));
    host = host_port.substr(0, colon);
    port = host_port.substr(colon + 1);
  }
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE;
  addrinfo* res = nullptr;
  if (const int rc = ::getaddrinfo(host.c_str(), port.c_str(), &hints, &res); rc != 0 || !res)
    throw HdrdError(make_error("server.tcp", fmt::format("tcp_listen '{}': {}", host_port, gai_strerror(rc)),
                               "server.tcp_listen"));
  bool loopback = false;
  if (res->ai_family == AF_INET) {
    const auto* a = reinterpret_cast<const sockaddr_in*>(res->ai_addr);
    loopback = (ntohl(a->sin_addr.s_addr) >> 24) == 127;
  } else if (res->ai_family == AF_INET6) {
    const auto* a = reinterpret_cast<const sockaddr_in6*>(res->ai_addr);
    loopback = IN6_IS_ADDR_LOOPBACK(&a->sin6_addr);
  }
  if (!loopback && !allow_non_loopback) {
    ::freeaddrinfo(res);
    throw HdrdError(make_error("server.tcp",
                               fmt::format("tcp_listen '{}' is not a loopback address; set "
                                           "server.tcp_allow_non_loopback = true to allow it", host_port),
                               "server.tcp_listen"));
  }
  const int fd = ::socket(res->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    ::freeaddrinfo(res);
    sys_fail("socket(TCP)");
  }
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  const int rc = ::bind(fd, res->ai_addr, res->ai_addrlen);
  ::freeaddrinfo(res);
  Listener l(fd, "tcp:" + host_port, false);
  if (rc != 0) sys_fail("bind " + host_port);
  if (::listen(fd, backlog) != 0) sys_fail("listen " + host_port);
  return l;
}

std::vector<int> systemd_listen_fds() {
  constexpr int kListenFdsStart = 3;  // SD_LISTEN_FDS_START
  std::vector<int> fds;
  const char* pid_s = std::getenv("LISTEN_PID");
  const char* n_s = std::getenv("LISTEN_FDS");
  if (pid_s && n_s) {
    char* end = nullptr;
    const long pid = std::strtol(pid_s, &end, 10);
    const bool pid_ok = end && *end == '\0' && pid == long(::getpid());
    const long n = std::strtol(n_s, &end, 10);
    if (pid_ok && end && *end == '\0' && n > 0 && n < 64)
      for (int fd = kListenFdsStart; fd < kListenFdsStart + int(n); ++fd) {
        ::fcntl(fd, F_SETFD, FD_CLOEXEC);
        fds.push_back(fd);
      }
  }
  ::unsetenv("LISTEN_PID");
  ::unsetenv("LISTEN_FDS");
  ::unsetenv("LISTEN_FDNAMES");
  return fds;
}

std::optional<PeerCred> peer_credentials(int fd) {
  ucred c{};
  socklen_t len = sizeof c;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &c, &len) != 0 || len != sizeof c) return std::nullopt;
  sockaddr_storage ss{};
  socklen_t sl = sizeof ss;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&ss), &sl) != 0 || ss.ss_family != AF_UNIX) return std::nullopt;
  return PeerCred{c.pid, c.uid, c.gid};
}

bool peer_hung_up(int fd) {
  pollfd p{fd, POLLRDHUP, 0};
  if (::poll(&p, 1, 0) <= 0) return false;
  return (p.revents & (POLLHUP | POLLRDHUP | POLLERR | POLLNVAL)) != 0;
}

}  // namespace hdrd::daemon

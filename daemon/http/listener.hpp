// Listening sockets: a Unix domain socket created, bound and listened here (mode 0660,
// so only the owner and group can connect), one inherited through systemd socket
// activation (sd_listen_fds(3) semantics: LISTEN_PID, LISTEN_FDS, fds from 3), or an
// opt-in TCP socket (loopback unless explicitly allowed). Each is an RAII owner.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace hdrd::daemon {

class Listener {
 public:
  Listener() = default;
  Listener(int fd, std::string description, bool is_unix, std::filesystem::path unlink_path = {});
  ~Listener();
  Listener(Listener&& o) noexcept { *this = std::move(o); }
  Listener& operator=(Listener&& o) noexcept;
  Listener(const Listener&) = delete;
  Listener& operator=(const Listener&) = delete;

  int fd() const { return fd_; }
  bool is_unix() const { return is_unix_; }
  const std::string& description() const { return description_; }
  // Gives up ownership of the fd (after MHD_quiesce_daemon hands it back, for instance).
  int release();
  void close();

 private:
  int fd_ = -1;
  std::string description_;
  bool is_unix_ = false;
  std::filesystem::path unlink_path_;  // socket file we created and remove on close, if it is still ours:
  dev_t unlink_dev_ = 0;               // the inode bind() made; another daemon's socket at the same
  ino_t unlink_ino_ = 0;               // path (after ours was replaced) is left alone
};

// Creates the socket's directory if needed (mode 0750... not widened if it exists),
// refuses to replace a live socket or a non-socket file, replaces a stale socket file,
// binds with a umask that never exposes the socket, then chmods it to `mode` and
// optionally chgrps it. Throws HdrdError on failure.
// The backlog is the kernel's maximum (net.core.somaxconn caps it): a burst of connects
// waits there while the server accepts, instead of being refused.
Listener listen_unix(const std::filesystem::path& path, unsigned mode, const std::string& group, int backlog = 4096);

// "host:port" or "[v6]:port". Throws unless the address is loopback or `allow_non_loopback`.
Listener listen_tcp(const std::string& host_port, bool allow_non_loopback, int backlog = 4096);

// sd_listen_fds(3): the fds systemd passed (LISTEN_PID must be ours), marked close-on-exec;
// unsets LISTEN_PID/LISTEN_FDS/LISTEN_FDNAMES so children do not inherit them.
std::vector<int> systemd_listen_fds();

// Peer credentials of a connected Unix socket (SO_PEERCRED), nullopt for other sockets.
struct PeerCred {
  pid_t pid = 0;
  uid_t uid = 0;
  gid_t gid = 0;
};
std::optional<PeerCred> peer_credentials(int fd);

// Whether a connected peer has hung up (POLLHUP/POLLRDHUP/POLLERR), without reading.
bool peer_hung_up(int fd);

}  // namespace hdrd::daemon

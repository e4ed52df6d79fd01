#include "encode/io/beneath.hpp"

#include <fcntl.h>
#include <linux/openat2.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <optional>
#include <vector>

#include <fmt/format.h>

namespace hdrd::io {
namespace fs = std::filesystem;

UniqueFd& UniqueFd::operator=(UniqueFd&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = o.release();
  }
  return *this;
}

UniqueFd::~UniqueFd() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {

// O_NONBLOCK: opening a FIFO or a device returns at once (regular files ignore the flag);
// O_NOCTTY: a terminal never becomes ours.
constexpr int kReadFlags = O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY | O_NOFOLLOW;
constexpr std::size_t kMaxPathBytes = 4096;

std::string shown(std::string_view path) { return one_line(path.substr(0, 256)); }

const char* kind_of(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a regular file";
}

// What the path itself can be refused for, before anything is opened.
std::optional<Error> check_relative(std::string_view rel, const Root& root) {
  if (rel.empty()) return make_error("path.invalid", "empty path");
  if (rel.size() > kMaxPathBytes) return make_error("path.invalid", fmt::format("path longer than {} bytes", kMaxPathBytes));
  if (rel.find('\0') != std::string_view::npos) return make_error("path.invalid", "path contains a NUL byte");
  if (rel.front() == '/')
    return make_error("path.forbidden", fmt::format("{}: an absolute path, beneath {} only relative ones", shown(rel),
                                                    root.options().what));
  for (std::size_t start = 0; start <= rel.size();) {
    const std::size_t end = std::min(rel.find('/', start), rel.size());
    if (rel.substr(start, end - start) == "..")
      return make_error("path.forbidden", fmt::format("{}: '..' is not allowed in paths", shown(rel)));
    start = end + 1;
  }
  return std::nullopt;
}

// The opened file must be a regular file, and (unless the root allows them) have one link:
// a hard link made inside the root to a file outside is that outside file.
Result<UniqueFd> check_opened(UniqueFd fd, std::string_view rel, const Root* root) {
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0)
    return make_error("io.read", fmt::format("cannot read {}: {}", shown(rel), std::strerror(errno)));
  const std::string where = root ? " in " + root->options().what : std::string();
  if (!S_ISREG(st.st_mode))
    return make_error("path.not_regular", fmt::format("{}{} is {}, not a regular file", shown(rel), where, kind_of(st.st_mode)));
  if (root && !root->options().allow_hard_links && st.st_nlink > 1)
    return make_error("path.hard_link",
                      fmt::format("{}{} has {} hard links; hard links are refused ([paths] allow_hard_links)", shown(rel),
                                  where, st.st_nlink));
  return fd;
}

Error open_error(int err, std::string_view rel, const Root& root, std::string_view component = {}) {
  const std::string& what = root.options().what;
  switch (err) {
    case ENOENT: return make_error("path.not_found", fmt::format("{}: no such file in {}", shown(rel), what));
    case ELOOP:
      return make_error("path.symlink",
                        component.empty()
                            ? fmt::format("{} in {} is a symbolic link; links are not followed", shown(rel), what)
                            : fmt::format("{}: '{}' is a symbolic link; links are not followed", shown(rel), shown(component)));
    case EXDEV: return make_error("path.forbidden", fmt::format("{}: leads outside {}", shown(rel), what));
    case ENOTDIR:
      return make_error("path.not_found",
                        fmt::format("{}: {} is not a directory", shown(rel), component.empty() ? "a component" : "'" + shown(component) + "'"));
    case EACCES:
    case EPERM: return make_error("path.forbidden", fmt::format("{}: permission denied", shown(rel)));
    default: return make_error("io.read", fmt::format("cannot open {}: {}", shown(rel), std::strerror(err)));
  }
}

int retry_eintr(auto&& call) {
  int r;
  do r = call();
  while (r < 0 && errno == EINTR);
  return r;
}

}  // namespace

Result<std::shared_ptr<const Root>> Root::open(const fs::path& dir, RootOptions options) {
  std::error_code ec;
  fs::path canon = fs::canonical(dir, ec);
  if (ec) return make_error("path.not_found", fmt::format("{}: {}", shown(dir.string()), ec.message()));
  const int fd = retry_eintr([&] { return ::open(canon.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC); });
  if (fd < 0) return make_error("path.not_regular", fmt::format("{}: not a directory ({})", shown(dir.string()), std::strerror(errno)));
  return std::shared_ptr<const Root>(new Root(UniqueFd(fd), std::move(canon), std::move(options)));
}

Result<UniqueFd> open_beneath_walk(const Root& root, std::string_view rel) {
  if (auto bad = check_relative(rel, root)) return *bad;
  std::vector<std::string> parts;
  for (std::size_t start = 0; start <= rel.size();) {
    const std::size_t end = std::min(rel.find('/', start), rel.size());
    const std::string_view part = rel.substr(start, end - start);
    if (!part.empty() && part != ".") parts.emplace_back(part);
    start = end + 1;
  }
  if (parts.empty())
    return make_error("path.not_regular", fmt::format("{}: is {} itself, not a file", shown(rel), root.options().what));
  UniqueFd dir;
  int at = root.fd();
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    const int fd = retry_eintr([&] { return ::openat(at, parts[i].c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC); });
    struct stat st {};
    if (fd < 0) {
      const int err = errno;
      const bool link = ::fstatat(at, parts[i].c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode);
      return open_error(link ? ELOOP : err, rel, root, parts[i]);
    }
    dir = UniqueFd(fd);
    if (::fstat(fd, &st) != 0 || !S_ISDIR(st.st_mode))  // O_PATH | O_NOFOLLOW may open the link itself
      return open_error(S_ISLNK(st.st_mode) ? ELOOP : ENOTDIR, rel, root, parts[i]);
    at = fd;
  }
  const int fd = retry_eintr([&] { return ::openat(at, parts.back().c_str(), kReadFlags); });
  if (fd < 0) return open_error(errno, rel, root);
  return check_opened(UniqueFd(fd), rel, &root);
}

Result<UniqueFd> open_beneath(const Root& root, std::string_view rel) {
  static std::atomic<bool> have_openat2{true};
  if (!have_openat2.load(std::memory_order_relaxed)) return open_beneath_walk(root, rel);
  if (auto bad = check_relative(rel, root)) return *bad;
  open_how how{};
  how.flags = static_cast<std::uint64_t>(kReadFlags);
  how.resolve = RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS | RESOLVE_NO_MAGICLINKS;
  const std::string path(rel);
  const int fd = retry_eintr([&] { return static_cast<int>(::syscall(SYS_openat2, root.fd(), path.c_str(), &how, sizeof how)); });
  if (fd >= 0) return check_opened(UniqueFd(fd), rel, &root);
  const int err = errno;
  if (err == ENOSYS) {  // Linux before 5.6
    have_openat2.store(false, std::memory_order_relaxed);
    return open_beneath_walk(root, rel);
  }
  // A link or a non-directory on the way: the walk, which refuses the same, names the component.
  if (err == ELOOP || err == ENOTDIR) return open_beneath_walk(root, rel);
  return open_error(err, rel, root);
}

Result<UniqueFd> open_regular(const fs::path& path) {
  const std::string name = path.string();
  if (name.empty()) return make_error("path.invalid", "empty path");
  const int fd = retry_eintr([&] { return ::open(name.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY); });
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT) return make_error("path.not_found", fmt::format("{}: no such file", shown(name)));
    if (err == EACCES || err == EPERM) return make_error("path.forbidden", fmt::format("{}: permission denied", shown(name)));
    return make_error("io.read", fmt::format("cannot open {}: {}", shown(name), std::strerror(err)));
  }
  return check_opened(UniqueFd(fd), name, nullptr);
}

Result<std::string> read_all(int fd, std::string_view name, std::size_t max_bytes) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return make_error("io.read", fmt::format("cannot read {}: {}", shown(name), std::strerror(errno)));
  if (st.st_size < 0 || static_cast<std::uint64_t>(st.st_size) > max_bytes)
    return make_error("file.too_large", fmt::format("{} is {} bytes; the limit is {}", shown(name), st.st_size, max_bytes));
  std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::pread(fd, bytes.data() + got, bytes.size() - got, static_cast<off_t>(got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return make_error("io.read", fmt::format("cannot read {}: {}", shown(name), std::strerror(errno)));
    if (n == 0) break;  // shrank while read: what is there
    got += static_cast<std::size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

Result<std::string> read_prefix(int fd, std::string_view name, std::size_t max_bytes) {
  std::string bytes(max_bytes, '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = ::pread(fd, bytes.data() + got, bytes.size() - got, static_cast<off_t>(got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return make_error("io.read", fmt::format("cannot read {}: {}", shown(name), std::strerror(errno)));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

Result<FileIdentity> identity_of(int fd, std::string_view name) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return make_error("io.read", fmt::format("cannot stat {}: {}", shown(name), std::strerror(errno)));
  return FileIdentity{st.st_dev, st.st_ino, static_cast<std::int64_t>(st.st_size)};
}

Result<UniqueFd> InputFiles::open(const fs::path& path) const {
  if (!root && !as_given)
    return make_error("path.forbidden", fmt::format("{}: no asset root is configured, so no file can be read", shown(path.string())));
  if (!root) return open_regular(path);
  if (!path.is_absolute()) return open_beneath(*root, path.string());
  // An absolute path (a request's, resolved) must name the root's own path, component by
  // component; what follows is opened beneath the root's descriptor.
  auto r = root->path().begin(), re = root->path().end();
  auto p = path.begin(), pe = path.end();
  for (; r != re; ++r, ++p) {
    if (r->empty()) continue;
    if (p == pe || *p != *r)
      return make_error("path.forbidden", fmt::format("{}: lies outside {}", shown(path.string()), root->options().what));
  }
  fs::path rel;
  for (; p != pe; ++p)
    if (!p->empty()) rel /= *p;
  return open_beneath(*root, rel.string());
}

Result<std::string> InputFiles::read(const fs::path& path, std::size_t max_bytes) const {
  auto fd = open(path);
  if (!fd) return fd.error();
  return read_all(fd->get(), path.string(), max_bytes);
}

Error reader_error(Error e, std::string_view missing_code, std::string_view unreadable_code, std::string_view field) {
  if (e.code == "path.not_found") e.code = missing_code;
  else if (e.code == "io.read") e.code = unreadable_code;
  if (e.field.empty()) e.field = field;
  return e;
}

}  // namespace hdrd::io

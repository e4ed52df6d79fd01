#include "encode/io/private_copy.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <system_error>
#include <vector>

#include <fmt/format.h>

namespace hdrd::io {
namespace fs = std::filesystem;

Result<PrivateCopies> PrivateCopies::create() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = fmt::format("{}/hdrd-copies-XXXXXX", tmp && *tmp ? tmp : "/tmp");
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  if (!::mkdtemp(buf.data()))  // mode 0700
    return make_error("io.write", fmt::format("cannot make a private directory {}: {}", pattern, std::strerror(errno)));
  return PrivateCopies(fs::path(buf.data()));
}

PrivateCopies::~PrivateCopies() {
  if (dir_.empty()) return;
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

Result<fs::path> PrivateCopies::add(const fs::path& relative, std::string_view bytes) {
  const fs::path rel = relative.lexically_normal();
  if (rel.empty() || rel.is_absolute() || *rel.begin() == "..")
    return make_error("path.forbidden", fmt::format("{}: not a relative path inside the copy", one_line(relative.string())));
  const fs::path full = dir_ / rel;
  std::error_code ec;
  fs::create_directories(full.parent_path(), ec);
  if (ec) return make_error("io.write", fmt::format("{}: {}", full.string(), ec.message()));
  const int fd = ::open(full.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) {
    if (errno == EEXIST) return full;
    return make_error("io.write", fmt::format("{}: {}", full.string(), std::strerror(errno)));
  }
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      return make_error(err == ENOSPC ? "io.no_space" : "io.write", fmt::format("{}: {}", full.string(), std::strerror(err)));
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return full;
}

}  // namespace hdrd::io

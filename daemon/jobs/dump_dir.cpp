#include "daemon/jobs/dump_dir.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include "encode/io/io.hpp"

namespace fs = std::filesystem;

namespace hdrd::daemon {

DumpDirectory::DumpDirectory(fs::path dir) : dir_(std::move(dir)) {
  fd_ = ::open(dir_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) {
    spdlog::warn("dump directory {}: cannot open it to lock it; stale temporaries are not removed", dir_.string());
    return;
  }
  exclusive_ = ::flock(fd_, LOCK_EX | LOCK_NB) == 0;
  if (!exclusive_) {
    spdlog::warn("dump directory {} is in use by another hdrd; its temporary files are left alone", dir_.string());
    return;
  }
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (!io::is_atomic_write_temporary(name) || !entry.is_regular_file(ec)) continue;
    if (fs::remove(entry.path(), ec)) ++removed_;
  }
  // A sequence killed before it was done: its staging directory, and whatever its journal
  // says it had renamed into place already.
  removed_ += io::sweep_staging(dir_);
  if (removed_ > 0)
    spdlog::info("dump directory {}: removed {} stale temporary or staged file(s) left by an interrupted dump", dir_.string(),
                 removed_);
}

DumpDirectory::~DumpDirectory() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

}  // namespace hdrd::daemon

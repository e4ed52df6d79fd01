// The dump directory while the daemon uses it. An flock(2) on the directory itself says
// that no other hdrd writes there, so every temporary of an atomic write found at start
// belongs to a writer that died mid-dump (kill -9, power loss) and is removed (and so is a
// sequence's staging directory with the files its journal names, io::sweep_staging); a
// directory another running daemon holds is left alone (its temporaries may be live).
#pragma once

#include <cstddef>
#include <filesystem>

namespace hdrd::daemon {

class DumpDirectory {
 public:
  // Opens and locks `dir` (which exists); removes stale temporaries when the lock is ours.
  // Logs what it removed, or why it removed nothing.
  explicit DumpDirectory(std::filesystem::path dir);
  ~DumpDirectory();
  DumpDirectory(const DumpDirectory&) = delete;
  DumpDirectory& operator=(const DumpDirectory&) = delete;

  const std::filesystem::path& path() const { return dir_; }
  bool exclusive() const { return exclusive_; }
  std::size_t removed() const { return removed_; }

 private:
  std::filesystem::path dir_;
  int fd_ = -1;
  bool exclusive_ = false;
  std::size_t removed_ = 0;
};

}  // namespace hdrd::daemon

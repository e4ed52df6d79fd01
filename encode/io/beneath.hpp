// Opening input files at the moment they are read, beneath a directory handle: the file
// model of the daemon (docs/api.md "Security"). A path checked when a request arrives can
// be swapped afterwards (a symbolic link to a file outside, a FIFO that blocks the read, a
// hard link to a file outside), so the check that counts is the one made by the open that
// reads: openat2(RESOLVE_BENEATH | RESOLVE_NO_SYMLINKS) beneath the root's descriptor (or,
// on a kernel without openat2, a walk of O_NOFOLLOW opens, one component at a time), with
// O_NONBLOCK so that a FIFO or device never blocks, then fstat: a regular file, and not a
// hard link unless the root allows them. Readers then parse the bytes of that descriptor;
// they never open the path a second time.
//
// The CLI reads its user's own files as given (InputFiles without a root): no confinement,
// but the same O_NONBLOCK open and regular-file check, so a FIFO is refused, not waited on.
//
// Errors name the path and what is wrong:
//   path.invalid      empty, a NUL byte, longer than 4096 bytes
//   path.forbidden    absolute, a ".." component, or a path that leads outside the root
//   path.symlink      a component is a symbolic link
//   path.not_found    no such file
//   path.not_regular  a FIFO, a device, a socket, a directory
//   path.hard_link    a regular file with more than one link, in a root that refuses them
//   file.too_large    larger than the reader's limit
//   io.read           the read itself failed
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "encode/result.hpp"

namespace hdrd::io {

// An owned file descriptor, closed when it goes.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  UniqueFd(UniqueFd&& o) noexcept : fd_(o.release()) {}
  UniqueFd& operator=(UniqueFd&& o) noexcept;
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  ~UniqueFd();

  int get() const { return fd_; }
  int release() { const int fd = fd_; fd_ = -1; return fd; }
  explicit operator bool() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// What identifies a file on disk: the file a job wrote is the file served only while these
// match (GET /v1/jobs/{id}/result).
struct FileIdentity {
  dev_t device = 0;
  ino_t inode = 0;
  std::int64_t size = 0;
  bool operator==(const FileIdentity&) const = default;
};

struct RootOptions {
  bool allow_hard_links = false;  // [paths] allow_hard_links
  std::string what = "the asset root";  // in messages: "... leads outside the asset root"
};

// A directory as a capability: an O_PATH | O_DIRECTORY descriptor files are opened beneath.
class Root {
 public:
  // Opens `dir` (which must be a directory). Errors: path.not_found, path.not_regular.
  static Result<std::shared_ptr<const Root>> open(const std::filesystem::path& dir, RootOptions options = {});

  int fd() const { return fd_.get(); }
  const std::filesystem::path& path() const { return path_; }  // canonical, when opened
  const RootOptions& options() const { return options_; }

 private:
  Root(UniqueFd fd, std::filesystem::path path, RootOptions options)
      : fd_(std::move(fd)), path_(std::move(path)), options_(std::move(options)) {}
  UniqueFd fd_;
  std::filesystem::path path_;
  RootOptions options_;
};

// Opens the regular file `relative` beneath `root` for reading (O_RDONLY | O_NONBLOCK |
// O_CLOEXEC | O_NOCTTY), refusing every escape, link and non-regular file listed above.
Result<UniqueFd> open_beneath(const Root& root, std::string_view relative);

// The same without openat2: the O_NOFOLLOW walk open_beneath falls back to on ENOSYS
// (public so that the tests run both).
Result<UniqueFd> open_beneath_walk(const Root& root, std::string_view relative);

// Opens `path` as given (the CLI): O_NONBLOCK, and refuses what is not a regular file.
Result<UniqueFd> open_regular(const std::filesystem::path& path);

// The whole of an open regular file (from offset 0), at most `max_bytes`. `name` is shown
// in messages.
Result<std::string> read_all(int fd, std::string_view name, std::size_t max_bytes);

// The first `max_bytes` of an open file (fewer when it is shorter): a header.
Result<std::string> read_prefix(int fd, std::string_view name, std::size_t max_bytes);

// The identity of an open file (fstat).
Result<FileIdentity> identity_of(int fd, std::string_view name);

// Where a job's inputs are read from: beneath a root (the daemon's asset root), or as given
// (no root: the CLI). A job carries one (job::JobOptions::files); every reader of a file a
// request names opens it through here, at the moment it reads.
struct InputFiles {
  std::shared_ptr<const Root> root;
  bool as_given = true;  // without a root: open paths as given (the CLI); false: refuse them all


  // `path` relative to the root, or absolute and (lexically) inside the root's path; with no
  // root, as given.
  Result<UniqueFd> open(const std::filesystem::path& path) const;
  Result<std::string> read(const std::filesystem::path& path, std::size_t max_bytes) const;
  bool confined() const { return root != nullptr || !as_given; }
};

// A reader's own codes for a file that is missing or cannot be read (exr.missing, ...): the
// file model's refusals (a link, a FIFO, outside the root, too large) keep their codes.
Error reader_error(Error e, std::string_view missing_code, std::string_view unreadable_code, std::string_view field = {});

// The default limit on one input file a reader takes whole (a LUT, an EDID, a scene, a map).
inline constexpr std::size_t kMaxInputFileBytes = std::size_t{1} << 30;

}  // namespace hdrd::io

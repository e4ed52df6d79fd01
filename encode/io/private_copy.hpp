// Verified copies of input files for a library that opens files by path itself
// (OpenColorIO reads its LUTs and the LUTs a config names). Handing such a library the path
// a request named would let it read whatever the path leads to when it reads (a symbolic
// link swapped in after the check, a FIFO, a hard link to a file outside the asset root):
// instead the bytes are read through the file model (encode/io/beneath.hpp), at the moment
// of use, and written to a directory only this process can reach, whose path the library
// is given. The directory and everything in it go when the PrivateCopies does.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "encode/result.hpp"

namespace hdrd::io {

class PrivateCopies {
 public:
  // A new private directory (mode 0700, mkdtemp beneath $TMPDIR or /tmp). Error: io.write.
  static Result<PrivateCopies> create();

  PrivateCopies(PrivateCopies&& o) noexcept : dir_(std::move(o.dir_)) { o.dir_.clear(); }
  PrivateCopies& operator=(PrivateCopies&&) = delete;
  PrivateCopies(const PrivateCopies&) = delete;
  PrivateCopies& operator=(const PrivateCopies&) = delete;
  ~PrivateCopies();

  const std::filesystem::path& dir() const { return dir_; }

  // Writes `bytes` as `relative` (a relative path without "..", its directories made as
  // needed) inside the private directory and returns the full path. A name written twice
  // keeps its first bytes. Errors: path.forbidden, io.write.
  Result<std::filesystem::path> add(const std::filesystem::path& relative, std::string_view bytes);

  // Where `relative` is (or would be) inside the private directory.
  std::filesystem::path map(const std::filesystem::path& relative) const { return dir_ / relative; }

 private:
  explicit PrivateCopies(std::filesystem::path dir) : dir_(std::move(dir)) {}
  std::filesystem::path dir_;
};

}  // namespace hdrd::io

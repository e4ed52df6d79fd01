// Paths named in requests: resolved inside a configured root only. A request may name
// a file relative to the root (or absolute, if it lies inside); ".." components are
// refused outright, and the canonical path (symlinks resolved) must still lie under the
// canonical root, so a symlink cannot lead out of it.
#pragma once

#include <filesystem>
#include <string_view>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::daemon {

// Resolves `requested` inside `root`. Errors: path.forbidden (no root, "..", outside the
// root after canonicalisation), path.not_found (no such file), path.invalid (empty, NUL,
// too long). `field` names the request field for the error.
Result<std::filesystem::path> resolve_in_root(const std::filesystem::path& root, std::string_view requested,
                                              std::string_view field);

// An EXR sequence named by a request (`images`: a printf pattern, a directory, a list
// file; job/sequence.hpp), inside `root`: a pattern's directory, a directory, a list file
// must lie inside (canonically, as resolve_in_root). Returns the spec with its directory
// canonical. Errors as resolve_in_root's.
Result<std::filesystem::path> resolve_sequence_in_root(const std::filesystem::path& root, std::string_view requested,
                                                       std::string_view field);

// Every file of a sequence (what its pattern, directory or list names) lies inside `root`
// once links are resolved, and is a regular file: path.forbidden / path.not_found naming
// the first that is not. A list file may name any path, a pattern's match may be a link.
Result<void> check_files_in_root(const std::filesystem::path& root, const std::vector<std::filesystem::path>& files,
                                 std::string_view field);

// True when `p` equals `root` or lies below it, comparing whole components (so that
// /srv/assets2 is not inside /srv/assets). Both must be canonical.
bool is_within(const std::filesystem::path& root, const std::filesystem::path& p);

// A dump base name: 1-100 characters of [A-Za-z0-9._-], not starting with '.'; it names
// files directly inside the dump directory, never a path.
Result<void> validate_dump_name(std::string_view name);

}  // namespace hdrd::daemon

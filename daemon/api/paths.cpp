#include "daemon/api/paths.hpp"

#include <string>


namespace fs = std::filesystem;

namespace hdrd::daemon {

bool is_within(const fs::path& root, const fs::path& p) {
  auto r = root.begin(), re = root.end();
  auto i = p.begin(), ie = p.end();
  for (; r != re; ++r, ++i) {
    if (r->empty()) continue;  // trailing separator of "/srv/assets/"
    if (i == ie || *i != *r) return false;
  }
  return true;
}

Result<fs::path> resolve_in_root(const fs::path& root, std::string_view requested, std::string_view field) {
  const std::string f(field);
  if (root.empty()) return make_error("path.forbidden", f + ": no asset root is configured, so requests cannot name files", f);
  if (requested.empty()) return make_error("path.invalid", f + ": empty path", f);
  if (requested.size() > 4096) return make_error("path.invalid", f + ": path longer than 4096 bytes", f);
  if (requested.find('\0') != std::string_view::npos) return make_error("path.invalid", f + ": path contains a NUL byte", f);
  const fs::path p{std::string(requested)};
  for (const auto& part : p)
    if (part == "..") return make_error("path.forbidden", f + ": '..' is not allowed in paths", f);

  std::error_code ec;
  const fs::path canon_root = fs::canonical(root, ec);
  if (ec) return make_error("path.forbidden", f + ": the asset root does not exist", f);
  const fs::path full = p.is_absolute() ? p : canon_root / p;
  // Lexical check first, so that probing outside the root cannot tell "exists" from "missing".
  if (!is_within(canon_root, full.lexically_normal()) && !is_within(root, full.lexically_normal()))
    return make_error("path.forbidden", f + ": path lies outside the asset root", f);
  const fs::path canon = fs::canonical(full, ec);
  if (ec) return make_error("path.not_found", f + ": no such file in the asset root: " + one_line(requested), f);
  if (!is_within(canon_root, canon))
    return make_error("path.forbidden", f + ": path leads outside the asset root (symbolic link)", f);
  if (!fs::is_regular_file(canon, ec))
    return make_error("path.not_found", f + ": not a regular file: " + one_line(requested), f);
  return canon;
}

namespace {

// A sequence spec that is a printf pattern: its file name holds a % conversion.
bool is_pattern(const fs::path& p) { return p.filename().string().find('%') != std::string::npos; }

// The directory `requested` names, canonical and inside the root.
Result<fs::path> resolve_dir_in_root(const fs::path& canon_root, const fs::path& full, const std::string& f,
                                     std::string_view requested) {
  std::error_code ec;
  const fs::path canon = fs::canonical(full, ec);
  if (ec) return make_error("path.not_found", f + ": no such directory in the asset root: " + one_line(requested), f);
  if (!is_within(canon_root, canon))
    return make_error("path.forbidden", f + ": path leads outside the asset root (symbolic link)", f);
  if (!fs::is_directory(canon, ec)) return make_error("path.not_found", f + ": not a directory: " + one_line(requested), f);
  return canon;
}

}  // namespace

Result<fs::path> resolve_sequence_in_root(const fs::path& root, std::string_view requested, std::string_view field) {
  const std::string f(field);
  const fs::path p{std::string(requested)};
  std::error_code root_ec, ec;
  const fs::path canon_root = root.empty() ? fs::path() : fs::canonical(root, root_ec);
  const fs::path full = root.empty() || root_ec || p.is_absolute() ? p : canon_root / p;
  const bool pattern = is_pattern(p);
  // A list file (or one name, which the sequence then refuses) is a file like any other.
  if (!pattern && (root.empty() || root_ec || requested.empty() || !fs::is_directory(full, ec)))
    return resolve_in_root(root, requested, field);
  // A directory or a pattern's: the same refusals as a file's, then its canonical form.
  if (root.empty()) return make_error("path.forbidden", f + ": no asset root is configured, so requests cannot name files", f);
  if (root_ec) return make_error("path.forbidden", f + ": the asset root does not exist", f);
  if (requested.size() > 4096) return make_error("path.invalid", f + ": path longer than 4096 bytes", f);
  if (requested.find('\0') != std::string_view::npos) return make_error("path.invalid", f + ": path contains a NUL byte", f);
  for (const auto& part : p)
    if (part == "..") return make_error("path.forbidden", f + ": '..' is not allowed in paths", f);
  if (!is_within(canon_root, full.lexically_normal()) && !is_within(root, full.lexically_normal()))
    return make_error("path.forbidden", f + ": path lies outside the asset root", f);
  if (!pattern) return resolve_dir_in_root(canon_root, full, f, requested);
  auto canon_dir = resolve_dir_in_root(canon_root, full.parent_path(), f, requested);
  if (!canon_dir) return canon_dir.error();
  return *canon_dir / full.filename();
}

Result<void> check_files_in_root(const fs::path& root, const std::vector<fs::path>& files, std::string_view field) {
  const std::string f(field);
  std::error_code ec;
  const fs::path canon_root = fs::canonical(root, ec);
  if (ec) return make_error("path.forbidden", f + ": the asset root does not exist", f);
  for (const auto& file : files) {
    const fs::path canon = fs::canonical(file, ec);
    if (ec) return make_error("path.not_found", f + ": no such file in the asset root: " + one_line(file.string()), f);
    if (!is_within(canon_root, canon))
      return make_error("path.forbidden", f + ": " + one_line(file.filename().string()) + " lies outside the asset root", f);
    if (!fs::is_regular_file(canon, ec))
      return make_error("path.not_found", f + ": not a regular file: " + one_line(file.string()), f);
  }
  return {};
}

Result<void> validate_dump_name(std::string_view name) {
  if (name.empty() || name.size() > 100)
    return make_error("request.value", "name: must be 1 to 100 characters", "name");
  if (name.front() == '.') return make_error("request.value", "name: must not start with '.'", "name");
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    if (!ok) return make_error("request.value", "name: only letters, digits, '.', '_' and '-' are allowed", "name");
  }
  return {};
}

}  // namespace hdrd::daemon

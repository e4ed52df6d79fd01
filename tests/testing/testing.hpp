// Helpers shared by the tests: where the shared fixtures are, temp dirs, running hdrd.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace hdrd::testing {

// ../shared relative to the source tree (or $HDRD_SHARED_DIR); nullopt when absent.
std::optional<std::filesystem::path> shared_dir();
// A fixture path, or nullopt when ../shared is missing. Use with HDRD_REQUIRE_SHARED.
std::optional<std::filesystem::path> fixture(const std::string& relative);
// The build directory (for the built hdrd binary).
std::filesystem::path binary_dir();
std::filesystem::path source_dir();

// A fresh empty directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};
// Runs a shell command line, capturing stdout and stderr separately.
CommandResult run_command(const std::string& command_line);
// Path to the built `hdrd` program.
std::filesystem::path hdrd_binary();

std::string read_file(const std::filesystem::path& p);

}  // namespace hdrd::testing

// Skips the current test with a clear message when ../shared (or one fixture) is missing.
#define HDRD_REQUIRE_FIXTURE(var, rel)                                              \
  const auto var##_opt = ::hdrd::testing::fixture(rel);                             \
  if (!var##_opt) GTEST_SKIP() << "shared fixture missing: ../shared/" << (rel);    \
  const std::filesystem::path var = *var##_opt

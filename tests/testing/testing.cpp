#include "tests/testing/testing.hpp"

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <sys/wait.h>

namespace fs = std::filesystem;

namespace hdrd::testing {

fs::path source_dir() {
  if (const char* s = std::getenv("HDRD_SOURCE_DIR")) return s;
  return HDRD_DEFAULT_SOURCE_DIR;
}

fs::path binary_dir() {
  if (const char* s = std::getenv("HDRD_BINARY_DIR")) return s;
  return HDRD_DEFAULT_BINARY_DIR;
}

std::optional<fs::path> shared_dir() {
  fs::path p;
  if (const char* s = std::getenv("HDRD_SHARED_DIR")) p = s;
  else p = HDRD_DEFAULT_SHARED_DIR;
  std::error_code ec;
  if (fs::is_directory(p, ec)) return fs::weakly_canonical(p);
  return std::nullopt;
}

std::optional<fs::path> fixture(const std::string& relative) {
  auto s = shared_dir();
  if (!s) return std::nullopt;
  fs::path p = *s / relative;
  std::error_code ec;
  if (!fs::exists(p, ec)) return std::nullopt;
  return p;
}

TempDir::TempDir() {
  std::random_device rd;
  for (int i = 0; i < 100; ++i) {
    fs::path p = fs::temp_directory_path() / ("hdrd-test-" + std::to_string(rd()));
    std::error_code ec;
    if (fs::create_directory(p, ec)) {
      path_ = p;
      return;
    }
  }
  throw std::runtime_error("cannot create a temporary directory");
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

CommandResult run_command(const std::string& command_line) {
  TempDir tmp;
  const fs::path out = tmp / "out", err = tmp / "err";
  const std::string cmd = command_line + " >" + out.string() + " 2>" + err.string() + " </dev/null";
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_file(out);
  r.err = read_file(err);
  return r;
}

fs::path hdrd_binary() { return binary_dir() / "tools" / "hdrd"; }

}  // namespace hdrd::testing

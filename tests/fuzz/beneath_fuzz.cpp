// Fuzz target for the path opener (encode/io/beneath.cpp): any byte string as a relative path
// against a small fixed tree that holds every way out (links to outside at the last and at
// a middle component, a link loop, an absolute link, a hard link to an outside file, a
// FIFO, a directory). Beyond "no crash": whatever opens, through openat2 or the walk, is
// one of the regular one-link files inside the root, never anything outside; both agree on
// whether a path opens; and no open blocks (the FIFO).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string_view>
#include <utility>

#include "encode/io/beneath.hpp"

namespace fs = std::filesystem;
using namespace hdrd::io;

namespace {

struct Tree {
  fs::path dir;
  std::shared_ptr<const Root> root;
  std::set<std::pair<dev_t, ino_t>> allowed;  // the files inside that may open
};

std::pair<dev_t, ino_t> id_of(const fs::path& p) {
  struct stat st {};
  if (::lstat(p.c_str(), &st) != 0) std::abort();
  return {st.st_dev, st.st_ino};
}

const Tree& tree() {
  static const Tree t = [] {
    Tree t;
    char tmpl[] = "/tmp/hdrd-beneath-fuzz-XXXXXX";
    if (!::mkdtemp(tmpl)) std::abort();
    t.dir = tmpl;
    const fs::path root = t.dir / "root";
    fs::create_directories(root / "sub/deeper");
    fs::create_directories(t.dir / "outside");
    const auto write = [](const fs::path& p) { std::ofstream(p) << p.filename().string(); };
    write(root / "a.txt");
    write(root / "sub/b.txt");
    write(root / "sub/deeper/c.txt");
    write(t.dir / "outside/secret.txt");
    write(t.dir / "outside/hard-target.txt");
    fs::create_symlink("../outside", root / "up");
    fs::create_symlink(t.dir / "outside/secret.txt", root / "out");
    fs::create_symlink(t.dir / "outside", root / "sub/abs");
    fs::create_symlink("../sub", root / "sub/loop");
    fs::create_symlink("a.txt", root / "alias.txt");
    fs::create_hard_link(t.dir / "outside/hard-target.txt", root / "hard.txt");
    if (::mkfifo((root / "fifo").c_str(), 0600) != 0) std::abort();
    for (const char* f : {"a.txt", "sub/b.txt", "sub/deeper/c.txt"}) t.allowed.insert(id_of(root / f));
    t.root = *Root::open(root);
    std::atexit([] { std::error_code ec; fs::remove_all(tree().dir, ec); });
    return t;
  }();
  return t;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Tree& t = tree();
  const std::string_view rel(reinterpret_cast<const char*>(data), size);
  auto a = open_beneath(*t.root, rel);
  auto b = open_beneath_walk(*t.root, rel);
  if (a.ok() != b.ok()) std::abort();  // openat2 and the walk disagree
  for (auto* r : {&a, &b}) {
    if (!r->ok()) {
      if (r->error().code.rfind("path.", 0) != 0 && r->error().code != "io.read") std::abort();
      continue;
    }
    struct stat st {};
    if (::fstat((*r)->get(), &st) != 0 || !S_ISREG(st.st_mode)) std::abort();
    if (!t.allowed.count({st.st_dev, st.st_ino})) std::abort();  // something not inside was opened
  }
  return 0;
}

// encode/io/beneath: files opened beneath a directory handle. Every case runs through both
// openat2 and the O_NOFOLLOW walk that stands in for it on kernels before 5.6.
#include "encode/io/beneath.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <future>
#include <thread>

#include <gtest/gtest.h>

#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

// root/               the root
//   a.txt             "inside"
//   sub/b.txt         "deep"
//   sub/deeper/c.txt  "deeper"
// outside/secret.txt  "secret"
class Beneath : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    fs::create_directories(dir_ / "root/sub/deeper");
    fs::create_directories(dir_ / "outside");
    write(dir_ / "root/a.txt", "inside");
    write(dir_ / "root/sub/b.txt", "deep");
    write(dir_ / "root/sub/deeper/c.txt", "deeper");
    write(dir_ / "outside/secret.txt", "secret");
    auto r = Root::open(dir_ / "root");
    ASSERT_TRUE(r.ok()) << r.error().message;
    root_ = *r;
  }
  fs::path root_path() const { return dir_ / "root"; }
  Result<UniqueFd> open(std::string_view rel, const Root* root = nullptr) const {
    const Root& r = root ? *root : *root_;
    return GetParam() ? open_beneath(r, rel) : open_beneath_walk(r, rel);
  }
  std::string read(std::string_view rel) const {
    auto fd = open(rel);
    if (!fd) return "error " + fd.error().code + ": " + fd.error().message;
    auto bytes = read_all(fd->get(), rel, 1 << 20);
    return bytes ? *bytes : "error " + bytes.error().code;
  }
  void expect_refused(std::string_view rel, std::string_view code) const {
    auto fd = open(rel);
    ASSERT_FALSE(fd.ok()) << rel << " opened";
    EXPECT_EQ(fd.error().code, code) << rel << ": " << fd.error().message;
    EXPECT_NE(fd.error().message.find(std::string(rel).substr(0, 20)), std::string::npos)
        << "the message names the path: " << fd.error().message;
  }

  testing::TempDir dir_;
  std::shared_ptr<const Root> root_;
};

TEST_P(Beneath, OpensRegularFilesAtAnyDepth) {
  EXPECT_EQ(read("a.txt"), "inside");
  EXPECT_EQ(read("sub/b.txt"), "deep");
  EXPECT_EQ(read("./sub//deeper/./c.txt"), "deeper");
}

TEST_P(Beneath, RefusesASymbolicLinkAtEveryComponent) {
  fs::create_symlink("a.txt", root_path() / "to-inside");                      // last component, target inside
  fs::create_symlink(dir_ / "outside/secret.txt", root_path() / "to-outside");  // last component, target outside
  fs::create_symlink("sub", root_path() / "sublink");                           // first of two
  fs::create_symlink("deeper", root_path() / "sub/deeplink");                   // middle of three
  fs::create_symlink(dir_ / "outside", root_path() / "sub/out");                // a directory outside
  fs::create_symlink("nowhere", root_path() / "dangling");
  for (const char* rel : {"to-inside", "to-outside", "sublink/b.txt", "sub/deeplink/c.txt", "sub/out/secret.txt", "dangling"})
    expect_refused(rel, "path.symlink");
  auto e = open("sub/deeplink/c.txt");
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("'deeplink' is a symbolic link"), std::string::npos) << e.error().message;
}

TEST_P(Beneath, RefusesDotDotAndAbsolutePaths) {
  for (const char* rel : {"..", "../outside/secret.txt", "sub/../a.txt", "sub/..", "sub/deeper/../../../outside/secret.txt"})
    expect_refused(rel, "path.forbidden");
  const std::string absolute = (dir_ / "outside/secret.txt").string();
  expect_refused(absolute, "path.forbidden");
  expect_refused((root_path() / "a.txt").string(), "path.forbidden");  // beneath takes relative paths only
  expect_refused("/etc/passwd", "path.forbidden");
}

TEST_P(Beneath, RefusesInvalidPaths) {
  EXPECT_EQ(open("").error().code, "path.invalid");
  EXPECT_EQ(open(std::string_view("a.txt\0x", 7)).error().code, "path.invalid");
  EXPECT_EQ(open(std::string(5000, 'a')).error().code, "path.invalid");
  expect_refused("missing.txt", "path.not_found");
  expect_refused("sub/missing/c.txt", "path.not_found");
  expect_refused("a.txt/x", "path.not_found");  // a file used as a directory
}

TEST_P(Beneath, RefusesADirectory) {
  expect_refused("sub", "path.not_regular");
  expect_refused("sub/deeper/", "path.not_regular");
}

// A FIFO would block an open for reading until a writer came: it must be refused at once.
TEST_P(Beneath, RefusesAFifoWithoutBlocking) {
  const fs::path fifo = root_path() / "frame.exr";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto task = std::async(std::launch::async, [&] { return open("frame.exr"); });
  if (task.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    ADD_FAILURE() << "opening a FIFO blocked";
    const int w = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // unblocks the reader
    if (w >= 0) ::close(w);
  }
  auto fd = task.get();
  ASSERT_FALSE(fd.ok());
  EXPECT_EQ(fd.error().code, "path.not_regular");
  EXPECT_NE(fd.error().message.find("FIFO"), std::string::npos) << fd.error().message;
}

TEST_P(Beneath, RefusesAHardLinkUnlessAllowed) {
  fs::create_hard_link(dir_ / "outside/secret.txt", root_path() / "linked.cube");
  expect_refused("linked.cube", "path.hard_link");
  auto lenient = Root::open(root_path(), {.allow_hard_links = true});
  ASSERT_TRUE(lenient.ok());
  auto fd = open("linked.cube", lenient->get());
  ASSERT_TRUE(fd.ok()) << fd.error().message;
  EXPECT_EQ(*read_all(fd->get(), "linked.cube", 100), "secret");
}

TEST_P(Beneath, RefusesDeviceFiles) {
  auto dev = Root::open("/dev", {.what = "/dev"});
  ASSERT_TRUE(dev.ok());
  for (const char* name : {"null", "zero", "urandom"}) {
    auto fd = open(name, dev->get());
    ASSERT_FALSE(fd.ok()) << name;
    EXPECT_EQ(fd.error().code, "path.not_regular") << fd.error().message;
    EXPECT_NE(fd.error().message.find("character device"), std::string::npos) << fd.error().message;
  }
}

// A file opened stays the file that was checked, whatever happens to its name afterwards.
TEST_P(Beneath, TheDescriptorIsTheFileThatWasChecked) {
  auto fd = open("a.txt");
  ASSERT_TRUE(fd.ok());
  fs::remove(root_path() / "a.txt");
  fs::create_symlink(dir_ / "outside/secret.txt", root_path() / "a.txt");
  EXPECT_EQ(*read_all(fd->get(), "a.txt", 100), "inside");
  expect_refused("a.txt", "path.symlink");
}

INSTANTIATE_TEST_SUITE_P(OpenAt2AndWalk, Beneath, ::testing::Bool(),
                         [](const auto& info) { return info.param ? "openat2" : "walk"; });

TEST(InputFiles, AbsolutePathsMustLieInTheRoot) {
  testing::TempDir dir;
  fs::create_directories(dir / "root/sub");
  write(dir / "root/sub/x.txt", "x");
  write(dir / "other.txt", "other");
  InputFiles files{*Root::open(dir / "root")};
  auto in = files.read(fs::canonical(dir / "root/sub/x.txt"), 100);
  ASSERT_TRUE(in.ok()) << in.error().message;
  EXPECT_EQ(*in, "x");
  EXPECT_EQ(*files.read("sub/x.txt", 100), "x");
  EXPECT_EQ(files.read(fs::canonical(dir / "other.txt"), 100).error().code, "path.forbidden");
  // /root2 is not inside /root: components are compared, not prefixes.
  fs::create_directories(dir / "root2");
  write(dir / "root2/y.txt", "y");
  EXPECT_EQ(files.read(fs::canonical(dir / "root2/y.txt"), 100).error().code, "path.forbidden");
  EXPECT_EQ(files.read(fs::canonical(dir / "root") / "sub/../../other.txt", 100).error().code, "path.forbidden");
}

TEST(InputFiles, WithoutARootReadsFilesAsGivenButRefusesWhatIsNotRegular) {
  testing::TempDir dir;
  write(dir / "x.txt", "x");
  fs::create_symlink(dir / "x.txt", dir / "link.txt");
  fs::create_hard_link(dir / "x.txt", dir / "hard.txt");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  const InputFiles cli;
  EXPECT_EQ(*cli.read(dir / "x.txt", 100), "x");
  EXPECT_EQ(*cli.read(dir / "link.txt", 100), "x");  // the user's own files: links are theirs
  EXPECT_EQ(*cli.read(dir / "hard.txt", 100), "x");
  auto fifo = cli.read(dir / "fifo", 100);
  ASSERT_FALSE(fifo.ok());
  EXPECT_EQ(fifo.error().code, "path.not_regular");
  EXPECT_EQ(cli.read("/dev/zero", 100).error().code, "path.not_regular");
  EXPECT_EQ(cli.read(dir.path(), 100).error().code, "path.not_regular");
  EXPECT_EQ(cli.read(dir / "missing", 100).error().code, "path.not_found");
}

TEST(InputFiles, ALimitIsAFileTooLarge) {
  testing::TempDir dir;
  write(dir / "big.txt", std::string(1000, 'x'));
  auto r = InputFiles{}.read(dir / "big.txt", 999);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "file.too_large");
  EXPECT_EQ(InputFiles{}.read(dir / "big.txt", 1000)->size(), 1000u);
}

TEST(FileIdentity, TellsAReplacedFile) {
  testing::TempDir dir;
  write(dir / "a", "abc");
  auto a = open_regular(dir / "a");
  const FileIdentity before = *identity_of(a->get(), "a");
  EXPECT_EQ(before.size, 3);
  fs::remove(dir / "a");
  write(dir / "a", "abc");
  auto b = open_regular(dir / "a");
  EXPECT_FALSE(*identity_of(b->get(), "a") == before);
}

}  // namespace
}  // namespace hdrd::io

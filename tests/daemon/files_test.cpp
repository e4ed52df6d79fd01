// End to end, the daemon's file model (issue 28 items 1-3; docs/api.md "Security"): inputs
// are opened when they are read, beneath the asset root; results are served only while
// they are the files the job wrote; names own their files; a killed sequence leaves no
// final-named file; the CLI cleans up on SIGINT/SIGTERM. Oracles: the file system, the wire
// codes of docs/api.md, the daemon's exit and timing.
//
// Swapping a frame "after the 202": the job is admitted while another holds the only
// sequence slot (max_running = 1), its frame is swapped while it waits (state queued,
// checked), then the blocker is cancelled and the job runs, reading the swapped frame.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "tests/daemon/daemon_harness.hpp"

namespace hdrd::testing {
namespace {

namespace fs = std::filesystem;
using daemon::ClientResponse;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

ClientResponse call(daemon::Client& c, const std::string& method, const std::string& path, const std::string& body = {}) {
  std::vector<std::pair<std::string, std::string>> headers;
  if (!body.empty()) headers.emplace_back("Content-Type", "application/json");
  auto r = c.request(method, path, body, headers);
  EXPECT_TRUE(r.ok()) << method << " " << path << ": " << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : ClientResponse{};
}

std::string error_code(const ClientResponse& r) {
  auto j = json::parse(r.body, nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "(not a JSON error: " + r.body.substr(0, 120) + ")";
}

Image frame(float level) {
  Image img(64, 32);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      float* p = img.px(x, y);
      p[0] = p[1] = p[2] = level * (1 + x / 64.0f);
      p[3] = 1;
    }
  return img;
}

void write_frame(const fs::path& p, float level) {
  io::ExrWriteOptions o;
  o.half = false;
  ASSERT_TRUE(io::write_exr(p, frame(level), o).ok()) << p;
}

// Every file in `dir` whose name starts with `name` (final-named files of that job).
std::vector<std::string> files_named(const fs::path& dir, const std::string& name) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(name, 0) == 0) out.push_back(e.path().filename().string());
  return out;
}

// Hidden staging directories, temporaries and spools of any job.
std::vector<std::string> hidden_entries(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().front() == '.') out.push_back(e.path().filename().string());
  return out;
}

class FileModel : public ::testing::Test {
 protected:
  void SetUp() override { start(); }

  void start() {
    daemon_ = std::make_unique<DaemonProcess>("drain_timeout_s = 5\n[sequences]\nmax_running = 1\nmax_queued = 8\n");
    ASSERT_TRUE(daemon_->ready()) << daemon_->log();
    const fs::path a = daemon_->assets();
    fs::create_directories(a / "shot");
    fs::create_directories(daemon_->dir() / "outside");
    for (int i = 0; i < 6; ++i) write_frame(a / "shot" / fmt::format("s.{:04d}.exr", i), 0.1f * float(i + 1));
    write_frame(daemon_->dir() / "outside" / "secret.exr", 42.0f);
    // The blocker: one small frame, 20000 times.
    std::ofstream list(a / "long.txt");
    for (int i = 0; i < 20000; ++i) list << "shot/s.0000.exr\n";
  }

  json submit(daemon::Client& c, const json& body) {
    auto r = call(c, "POST", "/v1/sequences", body.dump());
    EXPECT_EQ(r.status, 202) << r.body;
    return json::parse(r.body, nullptr, false);
  }
  json get(daemon::Client& c, const std::string& id) { return json::parse(call(c, "GET", "/v1/jobs/" + id).body, nullptr, false); }
  json wait_final(daemon::Client& c, const std::string& id, double limit_s = 60) {
    const auto end = Clock::now() + std::chrono::duration<double>(limit_s);
    json j;
    while (Clock::now() < end) {
      j = get(c, id);
      const std::string s = j.value("state", "");
      if (s == "done" || s == "failed" || s == "cancelled") return j;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "job " << id << " did not finish in " << limit_s << " s: " << j.dump();
    return j;
  }
  // A running blocker with frames written, so that the next job waits queued.
  std::string start_blocker(daemon::Client& c, const std::string& name = "blocker") {
    const std::string id = submit(c, {{"images", "long.txt"}, {"name", name}, {"formats", {"raw"}}}).value("id", "");
    for (int i = 0; i < 3000 && get(c, id).value("frames_done", 0) < 2; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_EQ(get(c, id).value("state", ""), "running");
    return id;
  }

  // Admits a 6-frame job behind the blocker, lets `swap` replace its frame 3 while it waits,
  // then releases it; returns its final state.
  json run_swapped(const std::string& name, const std::function<void(const fs::path&)>& swap) {
    auto c = daemon_->client(30);
    const std::string blocker = start_blocker(c);
    const std::string id = submit(c, {{"images", "shot/s.%04d.exr"}, {"name", name}, {"formats", {"raw"}}}).value("id", "");
    EXPECT_EQ(get(c, id).value("state", ""), "queued");
    const fs::path f = daemon_->assets() / "shot" / "s.0003.exr";
    fs::remove(f);
    swap(f);
    auto del = call(c, "DELETE", "/v1/jobs/" + blocker);
    EXPECT_EQ(del.status, 200) << del.body;
    return wait_final(c, id);
  }

  std::unique_ptr<DaemonProcess> daemon_;
};

TEST_F(FileModel, AFrameSwappedForALinkOutOfTheRootAfterThe202IsNotRead) {
  const fs::path secret = daemon_->dir() / "outside" / "secret.exr";
  const json job = run_swapped("linked", [&](const fs::path& f) { fs::create_symlink(secret, f); });
  ASSERT_EQ(job.value("state", ""), "failed") << job.dump(2);  // today's main: done, the outside file encoded
  EXPECT_EQ(job["error"].value("code", ""), "path.symlink") << job.dump(2);
  EXPECT_NE(job["error"].value("message", "").find("s.0003.exr"), std::string::npos) << job.dump(2);
  EXPECT_TRUE(files_named(daemon_->dumps(), "linked").empty());
}

TEST_F(FileModel, AFrameSwappedForAHardLinkToAnOutsideFileIsNotRead) {
  const fs::path secret = daemon_->dir() / "outside" / "secret.exr";
  const json job = run_swapped("hardlinked", [&](const fs::path& f) { fs::create_hard_link(secret, f); });
  ASSERT_EQ(job.value("state", ""), "failed") << job.dump(2);  // today's main: done
  EXPECT_EQ(job["error"].value("code", ""), "path.hard_link") << job.dump(2);
  EXPECT_TRUE(files_named(daemon_->dumps(), "hardlinked").empty());
}

TEST_F(FileModel, HardLinksAreReadWhenTheConfigAllowsThem) {
  // The same configuration with [paths] allow_hard_links = true, reloaded (SIGHUP).
  std::ofstream(daemon_->config()) << "[paths]\nasset_root = \"" << daemon_->assets().string() << "\"\ndump_dir = \""
                                   << daemon_->dumps().string() << "\"\nallow_hard_links = true\n[server]\nsocket_path = \""
                                   << daemon_->socket().string()
                                   << "\"\ndrain_timeout_s = 5\n[sequences]\nmax_running = 1\nmax_queued = 8\n";
  ASSERT_GT(daemon_->pid(), 0);
  ::kill(daemon_->pid(), SIGHUP);
  auto c = daemon_->client();
  for (int i = 0; i < 500 && call(c, "GET", "/metrics").body.find("hdrd_config_reloads_total 1") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_NE(call(c, "GET", "/metrics").body.find("hdrd_config_reloads_total 1"), std::string::npos) << daemon_->log();
  const fs::path secret = daemon_->dir() / "outside" / "secret.exr";
  const json job = run_swapped("allowed", [&](const fs::path& f) { fs::create_hard_link(secret, f); });
  EXPECT_EQ(job.value("state", ""), "done") << job.dump(2);
}

// A FIFO would block the job's read for ever (today's main: DELETE never answers, the only
// slot stays taken, SIGTERM does not stop the daemon within drain_timeout_s).
TEST_F(FileModel, AFrameSwappedForAFifoFailsAtOnceAndFreesTheSlot) {
  const json job = run_swapped("fifo", [](const fs::path& f) { ASSERT_EQ(::mkfifo(f.c_str(), 0600), 0); });
  ASSERT_EQ(job.value("state", ""), "failed") << job.dump(2);
  EXPECT_EQ(job["error"].value("code", ""), "path.not_regular") << job.dump(2);
  EXPECT_NE(job["error"].value("message", "").find("FIFO"), std::string::npos) << job.dump(2);
  auto c = daemon_->client(10);
  auto del = call(c, "DELETE", "/v1/jobs/" + job.value("id", ""));
  EXPECT_EQ(del.status, 200) << del.body;
  // The slot is free: the next job runs to the end.
  fs::remove(daemon_->assets() / "shot" / "s.0003.exr");
  write_frame(daemon_->assets() / "shot" / "s.0003.exr", 0.4f);
  const json next = wait_final(c, submit(c, {{"images", "shot/s.%04d.exr"}, {"name", "after"}, {"formats", {"raw"}}}).value("id", ""));
  EXPECT_EQ(next.value("state", ""), "done") << next.dump(2);
  // And SIGTERM with a FIFO in a running job's way still stops the daemon in its drain time.
  const std::string blocker = start_blocker(c, "blocker2");
  const std::string id = submit(c, {{"images", "shot/s.%04d.exr"}, {"name", "fifo2"}, {"formats", {"raw"}}}).value("id", "");
  EXPECT_EQ(get(c, id).value("state", ""), "queued");
  fs::remove(daemon_->assets() / "shot" / "s.0003.exr");
  ASSERT_EQ(::mkfifo((daemon_->assets() / "shot" / "s.0003.exr").c_str(), 0600), 0);
  call(c, "DELETE", "/v1/jobs/" + blocker);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto t0 = Clock::now();
  EXPECT_EQ(daemon_->stop(SIGTERM, std::chrono::seconds(30)), 0) << daemon_->log();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 5.0 + 2.0);
}

TEST_F(FileModel, AResultOrSidecarSwappedAfterTheJobIsGone) {
  auto c = daemon_->client(30);
  auto run = [&](const std::string& name) {
    const json j = wait_final(c, submit(c, {{"images", "shot/s.%04d.exr"}, {"name", name}, {"formats", {"raw"}},
                                            {"display", {{"mode", "sdr"}}}, {"video", {{"codec", "h264"}, {"preset", "ultrafast"}}}})
                                     .value("id", ""));
    EXPECT_EQ(j.value("state", ""), "done") << j.dump(2);
    return j;
  };
  const json a = run("served");
  EXPECT_EQ(call(c, "GET", "/v1/jobs/" + a.value("id", "") + "/result").status, 200);
  EXPECT_EQ(call(c, "GET", "/v1/jobs/" + a.value("id", "") + "/sidecar").status, 200);
  const fs::path video = a["files"].value("video", ""), sidecar = a["files"].value("sidecar", "");
  const fs::path secret = daemon_->dir() / "outside" / "secret.exr";
  // The video for a symbolic link to an outside file (today's main: 200 with that file).
  fs::remove(video);
  fs::create_symlink(secret, video);
  auto r = call(c, "GET", "/v1/jobs/" + a.value("id", "") + "/result");
  EXPECT_EQ(r.status, 410) << r.body;
  EXPECT_EQ(error_code(r), "job.file_changed");
  // The sidecar for a hard link to an outside file.
  fs::remove(sidecar);
  fs::create_hard_link(secret, sidecar);
  r = call(c, "GET", "/v1/jobs/" + a.value("id", "") + "/sidecar");
  EXPECT_EQ(r.status, 410) << r.body;
  EXPECT_EQ(error_code(r), "job.file_changed");
  // Another job's sidecar moved over it: another inode.
  const json b = run("other");
  fs::remove(sidecar);
  fs::copy_file(b["files"].value("sidecar", ""), sidecar);
  r = call(c, "GET", "/v1/jobs/" + a.value("id", "") + "/sidecar");
  EXPECT_EQ(r.status, 410) << r.body;
}

// Name ownership is per file: a name whose files could be another name's is refused before
// the 202 (today's main: "clash.00001" writes clash.00001.json, frame 1's sidecar of "clash").
TEST_F(FileModel, NamesWhoseFilesCouldBeAnothersAreRefused) {
  auto c = daemon_->client(30);
  for (const char* name : {"clash.00001", "col.00001", "x.hdr10plus", "x.dovi", "x.scene", "x.heatmap", "a.b.00042"}) {
    auto r = call(c, "POST", "/v1/sequences", json{{"images", "shot/s.%04d.exr"}, {"name", name}, {"formats", {"raw"}}}.dump());
    EXPECT_EQ(r.status, 422) << name << ": " << r.body;
    EXPECT_EQ(error_code(r), "name.collision") << name;
    // A single-frame dump under that name: the same rule (col.00001 would replace col.00001.png).
    auto p = call(c, "POST", "/v1/pattern", json{{"pattern", "window"}, {"dump", true}, {"name", name}}.dump());
    EXPECT_EQ(p.status, 422) << name << ": " << p.body;
    EXPECT_EQ(error_code(p), "name.collision") << name;
  }
  for (const char* name : {"clash", "clash.v2", "shot.0001", "x.hdr10", "col.00001a"}) {
    auto r = call(c, "POST", "/v1/sequences", json{{"images", "shot/s.%04d.exr"}, {"name", name}, {"formats", {"raw"}}}.dump());
    EXPECT_EQ(r.status, 202) << name << ": " << r.body;
    if (r.status == 202) wait_final(c, json::parse(r.body).value("id", ""));
  }
}

// A name used again: the later job supersedes the earlier one and removes every file it owned
// (today's main: frames 2..5 of the 6-frame job stay, and no call can remove them).
TEST_F(FileModel, ReusingANameRemovesWhatTheEarlierJobWrote) {
  auto c = daemon_->client(30);
  const json six = wait_final(c, submit(c, {{"images", "shot/s.%04d.exr"}, {"name", "reuse"}, {"formats", {"raw"}}}).value("id", ""));
  ASSERT_EQ(six.value("state", ""), "done") << six.dump(2);
  ASSERT_TRUE(fs::exists(daemon_->dumps() / "reuse.00005.raw"));
  const json two = wait_final(c, submit(c, {{"images", "shot/s.%04d.exr"}, {"frames", 2}, {"name", "reuse"}, {"formats", {"raw"}}})
                                     .value("id", ""));
  ASSERT_EQ(two.value("state", ""), "done") << two.dump(2);
  for (int i = 2; i < 6; ++i) EXPECT_FALSE(fs::exists(daemon_->dumps() / fmt::format("reuse.{:05d}.raw", i))) << i;
  for (int i = 0; i < 2; ++i) EXPECT_TRUE(fs::exists(daemon_->dumps() / fmt::format("reuse.{:05d}.raw", i))) << i;
  EXPECT_TRUE(fs::exists(daemon_->dumps() / "reuse.json"));
  EXPECT_EQ(get(c, six.value("id", "")).value("superseded_by", ""), two.value("id", ""));
  // DELETE of the later job removes everything of that name.
  EXPECT_EQ(call(c, "DELETE", "/v1/jobs/" + two.value("id", "")).status, 200);
  EXPECT_TRUE(files_named(daemon_->dumps(), "reuse").empty());
}

// kill -9 in the middle of a sequence: no final-named file of it exists, then or after the
// restart, and the restart sweeps its staging (today's main: NAME.NNNNN.raw files stay).
TEST_F(FileModel, AKilledSequenceLeavesNoFinalNamedFiles) {
  auto c = daemon_->client(30);
  const std::string id = start_blocker(c, "killed");
  for (int i = 0; i < 3000 && get(c, id).value("frames_done", 0) < 20; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GT(daemon_->pid(), 0);
  daemon_->stop(SIGKILL);  // kill -9 (stop() signals its own child only)
  EXPECT_TRUE(files_named(daemon_->dumps(), "killed").empty());
  EXPECT_FALSE(hidden_entries(daemon_->dumps()).empty()) << "the staging directory of the killed job";
  // The restart: the same dump directory.
  DaemonProcess again("", {"--dump-dir", daemon_->dumps().string()});
  ASSERT_TRUE(again.ready()) << again.log();
  EXPECT_TRUE(files_named(daemon_->dumps(), "killed").empty());
  const auto left = hidden_entries(daemon_->dumps());
  EXPECT_TRUE(left.empty()) << left.front();
}

// hdrd encode LIST --video h264 --format png -o X, then SIGTERM (and SIGINT): the CLI stops as
// the daemon's cancel does, leaves nothing named X* and no spool or staging, and says so in
// one line (today's main: the frames written so far and the video spool stay).
TEST(CliSignals, SigtermAndSigintDuringASequenceLeaveNothing) {
  TempDir dir;
  write_frame(dir / "f.exr", 0.5f);
  {
    std::ofstream list(dir / "long.txt");
    for (int i = 0; i < 20000; ++i) list << "f.exr\n";
  }
  fs::create_directories(dir / "out");
  for (const int sig : {SIGTERM, SIGINT}) {
    const fs::path err = dir / "err.txt";
    const pid_t pid = ::fork();
    if (pid == 0) {
      const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 2);
      const std::string bin = hdrd_binary().string(), list = (dir / "long.txt").string(), out = (dir / "out" / "X").string();
      ::execl(bin.c_str(), bin.c_str(), "encode", "--quiet", list.c_str(), "--mode", "sdr", "--video", "h264", "--format", "png",
              "-o", out.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ASSERT_GT(pid, 0);
    // Until it has written frames (into its staging directory).
    bool writing = false;
    for (int i = 0; i < 3000 && !writing; ++i) {
      std::error_code ec;
      for (const auto& e : fs::recursive_directory_iterator(dir / "out", ec))
        if (e.path().extension() == ".png") writing = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_TRUE(writing) << read_file(err);
    EXPECT_TRUE(files_named(dir / "out", "X").empty()) << "staged, not final-named";
    ::kill(pid, sig);
    int status = 0;
    const auto t0 = Clock::now();
    while (::waitpid(pid, &status, WNOHANG) == 0 && Clock::now() - t0 < std::chrono::seconds(30))
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (::waitpid(pid, &status, WNOHANG) == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      ADD_FAILURE() << "hdrd did not stop";
    }
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << "status " << status;
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(dir / "out")) left.push_back(e.path().filename().string());
    EXPECT_TRUE(left.empty()) << left.size() << " left, e.g. " << (left.empty() ? "" : left.front());
    const std::string text = read_file(err);
    EXPECT_NE(text.find(sig == SIGINT ? "interrupted by SIGINT" : "interrupted by SIGTERM"), std::string::npos) << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << "one line: " << text;
  }
}

}  // namespace
}  // namespace hdrd::testing

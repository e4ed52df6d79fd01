// The Slurm client (daemon/cluster/slurm.hpp) against the real one-node cluster that the ctest
// fixture cluster.slurm.start brings up (scripts/slurm-local.sh; HDRD_SLURM_DIR). Skips with
// the reason where there is none. The jobs run tests/cluster/stand_in_hdrd.sh (or HDRD_BIN)
// through tests/cluster/run_log_wrapper.sh, which logs every call and fails shards on demand.
#include <cstdlib>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "daemon/cluster/slurm.hpp"
#include "tests/testing/testing.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd::daemon::slurm;
using hdrd::testing::TempDir;

fs::path cluster_dir() {
  if (const char* d = std::getenv("HDRD_SLURM_DIR")) return d;
  return HDRD_DEFAULT_SLURM_DIR;
}

// SLURM_CONF from the cluster's env.sh ("export SLURM_CONF=..."), or empty.
fs::path slurm_conf() {
  std::ifstream f(cluster_dir() / "env.sh");
  std::string line;
  const std::regex re("^export SLURM_CONF=(.+)$");
  std::smatch m;
  while (std::getline(f, line))
    if (std::regex_match(line, m, re)) return m[1].str();
  return {};
}

class SlurmCluster : public ::testing::Test {
 protected:
  void SetUp() override {
    if (slurm_conf().empty()) {
      const auto check = hdrd::testing::run_command((hdrd::testing::source_dir() / "scripts/slurm-local.sh").string() + " check");
      GTEST_SKIP() << "no local Slurm cluster in " << cluster_dir() << ": "
                   << (check.exit_code == 0 ? "the fixture cluster.slurm.start did not start one" : check.out);
    }
    const fs::path cluster_tests = hdrd::testing::source_dir() / "tests/cluster";
    const char* program = std::getenv("HDRD_BIN");
    // The jobs inherit this environment (sbatch's default --export=ALL).
    ::setenv("HDRD_WRAPPED", program ? program : (cluster_tests / "stand_in_hdrd.sh").c_str(), 1);
    config_.scripts_dir = hdrd::testing::source_dir() / "deploy/slurm";
    config_.slurm_conf = slurm_conf();
    config_.hdrd_program = (cluster_tests / "run_log_wrapper.sh").string();
    config_.command_timeout = std::chrono::milliseconds(20000);
  }

  // A plan from the program under test (the stand-in takes --frames).
  fs::path make_plan(const std::string& name, int shards) {
    const fs::path plan = tmp_ / (name + ".plan.json");  // not OUTBASE.json, which a merge may write
    const char* extra = std::getenv("HDRD_PLAN_ARGS");
    const auto r = hdrd::testing::run_command(std::string(std::getenv("HDRD_WRAPPED")) + " sequence plan --shards " +
                                              std::to_string(shards) + " -o " + plan.string() + " " +
                                              (extra ? extra : "--frames 6"));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return plan;
  }

  // Polls progress until the merge (or the whole submission) has ended; at most 60 s.
  Progress wait(const Client& client, const Submission& s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    for (;;) {
      auto p = client.progress(s);
      EXPECT_TRUE(p) << p.error().message;
      if (!p) return {};
      const bool merge_ended = p->merge && p->merge->state != JobState::pending && p->merge->state != JobState::running;
      if (merge_ended || std::chrono::steady_clock::now() > deadline) return *p;
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  }

  TempDir tmp_;
  ClusterConfig config_;
};

TEST_F(SlurmCluster, SubmitsAPlanAndFollowsItToTheEnd) {
  const Client client(config_);
  const fs::path plan = make_plan("ok", 3);
  auto s = client.submit(plan, tmp_ / "ok");
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_GT(s->merge_job_id, s->array_job_id);
  auto first = client.progress(*s);
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_EQ(first->shards.size() + first->unknown_shards.size(), 3u);
  EXPECT_NE(first->state, JobState::failed);

  const Progress p = wait(client, *s);
  EXPECT_EQ(p.state, JobState::completed);
  EXPECT_EQ(p.completed, 3u);
  ASSERT_EQ(p.shards.size(), 3u);
  for (std::uint32_t i = 0; i < 3; ++i) {
    EXPECT_EQ(p.shards[i].job_id, s->array_job_id);
    EXPECT_EQ(p.shards[i].array_task, i);
    EXPECT_EQ(p.shards[i].slurm_state, "COMPLETED");
  }
  ASSERT_TRUE(p.merge);
  EXPECT_EQ(p.merge->slurm_state, "COMPLETED");
  EXPECT_TRUE(fs::exists(tmp_ / "ok.mp4"));
}

TEST_F(SlurmCluster, AFailedShardFailsTheSubmissionAndCancelsTheMerge) {
  const Client client(config_);
  const fs::path plan = make_plan("bad", 2);
  const auto header = read_plan_header(plan);
  ASSERT_TRUE(header);
  std::ofstream(header->work_dir / "fail-shard-0").close();
  auto s = client.submit(plan, tmp_ / "bad");
  ASSERT_TRUE(s) << s.error().message;
  const Progress p = wait(client, *s);
  EXPECT_EQ(p.state, JobState::failed);
  EXPECT_EQ(p.failed, 1u);
  EXPECT_EQ(p.completed, 1u);
  ASSERT_TRUE(p.merge);
  EXPECT_EQ(p.merge->state, JobState::cancelled);
  EXPECT_EQ(p.merge->reason, "DependencyNeverSatisfied");
  EXPECT_FALSE(fs::exists(tmp_ / "bad.mp4"));

  // The documented retry: the failed shard alone, and a merge after it.
  fs::remove(header->work_dir / "fail-shard-0");
  auto retry = client.submit(plan, tmp_ / "bad", SubmitOptions{{0}, std::nullopt});
  ASSERT_TRUE(retry) << retry.error().message;
  EXPECT_EQ(retry->shards.spec(), "0");
  const Progress again = wait(client, *retry);
  EXPECT_EQ(again.state, JobState::completed);
  EXPECT_TRUE(fs::exists(tmp_ / "bad.mp4"));
}

TEST_F(SlurmCluster, CancelStopsASubmission) {
  // A program that never finishes on its own.
  const fs::path slow = tmp_ / "slow.sh";
  std::ofstream(slow) << "#!/bin/sh\nexec sleep 120\n";
  fs::permissions(slow, fs::perms::owner_all);
  config_.hdrd_program = slow.string();
  const Client client(config_);
  auto s = client.submit(make_plan("slow", 2), tmp_ / "slow");
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_TRUE(client.cancel(*s));
  const Progress p = wait(client, *s);
  EXPECT_EQ(p.state, JobState::cancelled);
  ASSERT_TRUE(p.merge);
  EXPECT_EQ(p.merge->state, JobState::cancelled);
  EXPECT_EQ(p.cancelled, 2u);
}

}  // namespace

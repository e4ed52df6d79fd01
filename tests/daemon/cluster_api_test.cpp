// POST /v1/cluster/submissions, GET and DELETE /v1/cluster/submissions/{id} (docs/api.md,
// docs/cluster.md) on the running daemon, against stand-ins for sbatch, squeue, sacct and
// scancel that record their arguments and print what Slurm prints: the array job and the
// merge job after it are submitted with the plan and OUTBASE in the dump directory, the
// progress is Slurm's, DELETE cancels both; bad bodies are 4xx, no cluster is 503.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "tests/daemon/daemon_harness.hpp"

namespace hdrd::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

void write_exec(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  fs::permissions(p, fs::perms::owner_all);
}

daemon::ClientResponse call(DaemonProcess& d, const std::string& method, const std::string& path, const std::string& body = {}) {
  daemon::Client c(d.options());
  std::vector<std::pair<std::string, std::string>> headers;
  if (!body.empty()) headers.emplace_back("Content-Type", "application/json");
  auto r = c.request(method, path, body, headers);
  EXPECT_TRUE(r.ok());
  return r.ok() ? *r : daemon::ClientResponse{};
}

std::string code_of(const daemon::ClientResponse& r) {
  auto j = json::parse(r.body, nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "";
}

TEST(ClusterApi, SubmitsReportsAndCancelsThroughSlurm) {
  TempDir bin;
  const std::string log = (bin / "calls.log").string();
  const std::string record = "printf '%s\\n' \"$(basename \"$0\")\" \"$@\" --end-- >>" + log + "\n";
  // sbatch answers 4711 for the array, 4712 for the merge; squeue reports shard 0 done,
  // shard 1 running, the merge waiting on its dependency.
  write_exec(bin / "sbatch", "#!/bin/sh\n" + record + "n=$(grep -c -- '^--end--$' " + log + ")\n" +
                                 "[ \"$n\" = 1 ] && echo 4711 || echo 4712\n");
  write_exec(bin / "squeue", "#!/bin/sh\n" + record + "printf '4711|0|COMPLETED|None\\n4711|1|RUNNING|None\\n4712|N/A|PENDING|Dependency\\n'\n");
  write_exec(bin / "sacct", "#!/bin/sh\n" + record);
  write_exec(bin / "scancel", "#!/bin/sh\n" + record);
  DaemonProcess d("[cluster]\nslurm_scripts_dir = \"" + (source_dir() / "deploy/slurm").string() + "\"\nslurm_bin_dir = \"" +
                  bin.path().string() + "\"\nhdrd_program = \"/opt/hdrd\"\nsbatch_options = \"--partition=render\"\n");
  ASSERT_TRUE(d.ready()) << d.log();
  std::ofstream(d.assets() / "shot.json") << R"({"format": "hdrd-sequence-plan", "shards": 2, "frames": 10, "work_dir": "/shared/shot.d", "outbase": null})";

  auto r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "shot.json", "outbase": "shot"})");
  ASSERT_EQ(r.status, 202u) << r.body;
  const json sub = json::parse(r.body);
  EXPECT_EQ(sub["array_job_id"], "4711");
  EXPECT_EQ(sub["merge_job_id"], "4712");
  EXPECT_EQ(sub["shards"], 2);
  EXPECT_EQ(sub["array"], "0-1");
  const std::string calls = read_file(log);
  EXPECT_NE(calls.find("--array=0-1"), std::string::npos) << calls;
  EXPECT_NE(calls.find("--dependency=afterok:4711"), std::string::npos) << calls;
  EXPECT_NE(calls.find("--partition=render"), std::string::npos) << calls;
  EXPECT_NE(calls.find((d.dumps() / "shot").string()), std::string::npos) << "OUTBASE in the dump directory";

  r = call(d, "GET", "/v1/cluster/submissions/" + sub["id"].get<std::string>());
  ASSERT_EQ(r.status, 200u) << r.body;
  const json p = json::parse(r.body);
  EXPECT_EQ(p["state"], "running");
  EXPECT_EQ(p["counts"]["completed"], 1);
  EXPECT_EQ(p["counts"]["running"], 1);
  EXPECT_EQ(p["merge"]["reason"], "Dependency");

  r = call(d, "DELETE", "/v1/cluster/submissions/" + sub["id"].get<std::string>());
  EXPECT_EQ(r.status, 200u) << r.body;
  EXPECT_NE(read_file(log).find("scancel"), std::string::npos);

  EXPECT_EQ(call(d, "GET", "/v1/cluster/submissions/slurm-1").status, 404u);
  r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "../etc/passwd", "outbase": "x"})");
  EXPECT_EQ(r.status, 403u) << r.body;
  r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "shot.json", "outbase": "../x"})");
  EXPECT_EQ(r.status, 400u) << r.body;
  r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "shot.json", "outbase": "x", "speed": 1})");
  EXPECT_EQ(code_of(r), "request.unknown_field");
  // Issue 28.10: a valid 1e6-shard plan's submission answered an 11.9 MB body (every index)
  // and kept a 4 MB list for as long as the daemon remembers it; it keeps one range now.
  std::ofstream(d.assets() / "big.json")
      << R"({"format": "hdrd-sequence-plan", "shards": 1000000, "frames": 1000000, "work_dir": "/shared/big.d", "outbase": null})";
  r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "big.json", "outbase": "big"})");
  ASSERT_EQ(r.status, 202u) << r.body.substr(0, 200);
  EXPECT_LT(r.body.size(), 1024u) << "the answer lists every shard";
  EXPECT_EQ(json::parse(r.body)["array"], "0-999999");
  EXPECT_EQ(json::parse(r.body)["shards"], 1000000);
  std::ofstream(d.assets() / "bad.json") << R"({"format": "hdrd-sequence-plan", "shards": 0})";
  r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "bad.json", "outbase": "x"})");
  EXPECT_EQ(r.status, 422u) << r.body;
}

TEST(ClusterApi, WithoutAClusterIs503) {
  DaemonProcess d;
  ASSERT_TRUE(d.ready());
  auto r = call(d, "POST", "/v1/cluster/submissions", R"({"plan": "shot.json", "outbase": "x"})");
  EXPECT_EQ(r.status, 503u);
  EXPECT_EQ(code_of(r), "cluster.unavailable");
}

}  // namespace
}  // namespace hdrd::testing

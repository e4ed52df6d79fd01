// daemon/cluster/slurm.hpp and daemon/cluster/subprocess.hpp without a cluster: the parsers on outputs
// recorded from Slurm 22.05 (tests/daemon/data/slurm/README.md) and on malformed ones, the
// plan-header rules from the table deploy/lib/plan.sh is tested on, the subprocess runner,
// and the client against recording stand-ins for sbatch, squeue, sacct and scancel, whose
// sbatch command lines must equal deploy/slurm/submit.sh's.
#include <fcntl.h>
#include <sys/stat.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <sstream>

#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "daemon/cluster/slurm.hpp"
#include "daemon/cluster/subprocess.hpp"
#include "tests/testing/testing.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd;
using namespace hdrd::daemon;
using namespace hdrd::daemon::slurm;
using ::testing::HasSubstr;
using hdrd::testing::TempDir;

std::string recorded(const std::string& name) {
  return hdrd::testing::read_file(hdrd::testing::source_dir() / "tests/daemon/data/slurm" / name);
}

void write_file(const fs::path& p, const std::string& text, bool executable = false) {
  std::ofstream(p, std::ios::binary) << text;
  if (executable) ::chmod(p.c_str(), 0755);
}

// "job_task:state:reason" per row, task "-" for a plain job: a compact view for comparisons.
std::vector<std::string> rows(const std::vector<TaskStatus>& ts) {
  std::vector<std::string> out;
  for (const auto& t : ts)
    out.push_back(std::to_string(t.job_id) + "_" + (t.array_task ? std::to_string(*t.array_task) : "-") + ":" +
                  std::string(to_string(t.state)) + ":" + (t.reason.empty() ? t.exit_code : t.reason));
  return out;
}

// --- states -------------------------------------------------------------------------------

TEST(SlurmState, MapsEveryStateSlurmPrints) {
  const std::vector<std::pair<std::string, JobState>> table = {
      {"PENDING", JobState::pending},       {"REQUEUED", JobState::pending},   {"CONFIGURING", JobState::pending},
      {"RUNNING", JobState::running},       {"COMPLETING", JobState::running}, {"SUSPENDED", JobState::running},
      {"COMPLETED", JobState::completed},   {"FAILED", JobState::failed},      {"TIMEOUT", JobState::failed},
      {"NODE_FAIL", JobState::failed},      {"OUT_OF_MEMORY", JobState::failed}, {"PREEMPTED", JobState::failed},
      {"BOOT_FAIL", JobState::failed},      {"DEADLINE", JobState::failed},    {"CANCELLED", JobState::cancelled},
      {"REVOKED", JobState::cancelled},
  };
  for (const auto& [name, state] : table) {
    auto s = map_state(name);
    ASSERT_TRUE(s) << name;
    EXPECT_EQ(*s, state) << name;
  }
  auto bad = map_state("FINISHED");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, "slurm.state");
  EXPECT_EQ(bad.error().message, "unknown Slurm job state 'FINISHED'");
}

// --- sbatch --parsable ---------------------------------------------------------------------

TEST(SlurmParse, SbatchParsableRecorded) {
  auto id = parse_sbatch_parsable(recorded("sbatch.txt"));
  ASSERT_TRUE(id) << id.error().message;
  EXPECT_EQ(*id, 9u);
  auto with_cluster = parse_sbatch_parsable("4242;render-farm_2\n");
  ASSERT_TRUE(with_cluster);
  EXPECT_EQ(*with_cluster, 4242u);
}

TEST(SlurmParse, SbatchParsableRefusesAnythingElse) {
  for (const std::string bad : {"", "\n", "Submitted batch job 9\n", "0\n", "12;\n", "12;a b\n", "12\n13\n",
                                "99999999999999999999\n", "-3\n", "12 \n", " 12\n"}) {
    auto r = parse_sbatch_parsable(bad);
    ASSERT_FALSE(r) << "accepted '" << bad << "'";
    EXPECT_EQ(r.error().code, "slurm.sbatch_output");
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
}

// --- squeue --------------------------------------------------------------------------------

TEST(SlurmParse, SqueueRecordedThrottledArray) {
  auto r = parse_squeue(recorded("squeue-throttled.txt"));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(rows(*r), (std::vector<std::string>{
                          "10_2:pending:JobArrayTaskLimit", "10_3:pending:JobArrayTaskLimit",
                          "10_4:pending:JobArrayTaskLimit", "10_5:pending:JobArrayTaskLimit", "11_-:pending:Dependency",
                          "10_0:running:None", "10_1:running:None"}));
}

TEST(SlurmParse, SqueueExpandsTasksNotYetSplitOff) {
  auto split = parse_squeue(recorded("squeue-throttled.txt"));
  auto unsplit = parse_squeue(recorded("squeue-throttled-unsplit.txt"));
  ASSERT_TRUE(split && unsplit);
  auto a = rows(*split), b = rows(*unsplit);
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b) << "'10|2-5%2|PENDING' is tasks 2, 3, 4 and 5";
}

TEST(SlurmParse, SqueueRecordedFailedShardAndCancelledMerge) {
  auto failed = parse_squeue(recorded("squeue-failed-shard.txt"));
  ASSERT_TRUE(failed);
  EXPECT_THAT(rows(*failed), ::testing::Contains("10_3:failed:NonZeroExitCode"));
  auto ended = parse_squeue(recorded("squeue-merge-cancelled.txt"));
  ASSERT_TRUE(ended);
  EXPECT_EQ(rows(*ended).front(), "11_-:cancelled:DependencyNeverSatisfied");
  EXPECT_EQ(ended->front().slurm_state, "CANCELLED");
}

TEST(SlurmParse, SqueueRangesStepsAndBrackets) {
  auto r = parse_squeue("7|[1,4-5]|PENDING|None\n7|0-6:3|PENDING|None");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(rows(*r), (std::vector<std::string>{"7_1:pending:None", "7_4:pending:None", "7_5:pending:None",
                                                "7_0:pending:None", "7_3:pending:None", "7_6:pending:None"}));
  auto none = parse_squeue("");
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->empty());
}

struct Malformed {
  std::string name, text, message;
};
// ctest lists the case by name, not as gtest's dump of the struct's bytes.
void PrintTo(const Malformed& m, std::ostream* os) { *os << m.name; }

class SqueueMalformed : public ::testing::TestWithParam<Malformed> {};

TEST_P(SqueueMalformed, IsRefusedNamingLineAndField) {
  auto r = parse_squeue(GetParam().text);
  ASSERT_FALSE(r) << "accepted: " << GetParam().text;
  EXPECT_EQ(r.error().code, "slurm.squeue_output");
  EXPECT_EQ(r.error().message, GetParam().message);
}

INSTANTIATE_TEST_SUITE_P(
    Lines, SqueueMalformed,
    ::testing::Values(
        Malformed{"three_fields", "10|0|RUNNING\n", "line 1: expected 4 fields (job|task|state|reason), got 3"},
        Malformed{"five_fields", "10|0|RUNNING|None|x\n", "line 1: expected 4 fields (job|task|state|reason), got 5"},
        Malformed{"empty_line", "10|0|RUNNING|None\n\n10|1|RUNNING|None\n", "line 2 is empty"},
        Malformed{"carriage_return", "10|0|RUNNING|None\r\n", "line 1 has a carriage return"},
        Malformed{"unknown_state", "10|0|DONE|None\n", "line 1: unknown Slurm job state 'DONE'"},
        Malformed{"job_id_zero", "0|N/A|PENDING|None\n", "line 1: bad job id '0'"},
        Malformed{"job_id_text", "1x|N/A|PENDING|None\n", "line 1: bad job id '1x'"},
        Malformed{"job_id_overflow", "99999999999999999999|N/A|PENDING|None\n", "line 1: bad job id '99999999999999999999'"},
        Malformed{"backwards_range", "10|5-2|PENDING|None\n", "line 1: array index range '5-2' is backwards or beyond Slurm's limit"},
        Malformed{"range_beyond_limit", "10|0-4000001|PENDING|None\n", "line 1: array index range '0-4000001' is backwards or beyond Slurm's limit"},
        Malformed{"range_beyond_the_rows_expected", "10|0-4000000|PENDING|None\n", "line 1: more rows than the 100000 expected"},
        Malformed{"open_bracket", "10|[1-3|PENDING|None\n", "line 1: bad array index '[1-3'"},
        Malformed{"bad_throttle", "10|1-3%x|PENDING|None\n", "line 1: bad array throttle in '1-3%x'"},
        Malformed{"zero_step", "10|1-3:0|PENDING|None\n", "line 1: bad array step in '1-3:0'"},
        Malformed{"empty_task", "10||PENDING|None\n", "line 1: empty array index"},
        Malformed{"control_in_reason", std::string("10|1|PENDING|No\x01ne\n"), "line 1: bad reason 'No ne'"}),
    [](const auto& info) { return info.param.name; });

// --- sacct ---------------------------------------------------------------------------------

TEST(SlurmParse, SacctParsable2Layout) {
  // sacct(1) --parsable2 --allocations: JobID|State|ExitCode, one line per job or array task,
  // pending array tasks as one bracketed range.
  auto r = parse_sacct("20_0|COMPLETED|0:0\n20_1|FAILED|3:0\n20_2|CANCELLED by 1000|0:15\n20_[3-5%2]|PENDING|0:0\n"
                       "21|CANCELLED by 0|0:0\n22|OUT_OF_MEMORY|0:125\n");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(rows(*r), (std::vector<std::string>{"20_0:completed:0:0", "20_1:failed:3:0", "20_2:cancelled:0:15",
                                                "20_3:pending:0:0", "20_4:pending:0:0", "20_5:pending:0:0",
                                                "21_-:cancelled:0:0", "22_-:failed:0:125"}));
  EXPECT_EQ((*r)[2].slurm_state, "CANCELLED");
}

TEST(SlurmParse, RowsBeyondWhatWasAskedForAreRefused) {
  // The client asks about one array of 3 tasks and one merge job: 4 rows at most.
  ASSERT_TRUE(parse_squeue("7|0-2|PENDING|None\n8|N/A|PENDING|Dependency\n", 4));
  auto r = parse_squeue("7|0-4|PENDING|None\n8|N/A|PENDING|Dependency\n", 4);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().message, "line 1: more rows than the 4 expected");
  auto lines = parse_sacct("7_0|COMPLETED|0:0\n7_1|COMPLETED|0:0\n7_2|COMPLETED|0:0\n", 2);
  ASSERT_FALSE(lines);
  EXPECT_EQ(lines.error().message, "line 3: more rows than the 2 expected");
}

TEST(SlurmParse, SacctRefusesOtherShapes) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"20_0|COMPLETED|0:0|\n", "line 1: expected 3 fields (jobid|state|exitcode), got 4"},  // --parsable, not 2
      {"20_0.batch|COMPLETED|0:0\n", "line 1: bad array index '0.batch'"},                   // a step: no --allocations
      {"20+1|COMPLETED|0:0\n", "line 1: bad job id '20+1'"},                                  // a heterogeneous job
      {"20|COMPLETED|0\n", "line 1: bad exit code '0'"},
      {"20|CANCELLED by me|0:0\n", "line 1: bad state 'CANCELLED by me'"},
      {"20|Completed|0:0\n", "line 1: unknown Slurm job state 'Completed'"},
  };
  for (const auto& [text, message] : cases) {
    auto r = parse_sacct(text);
    ASSERT_FALSE(r) << "accepted: " << text;
    EXPECT_EQ(r.error().code, "slurm.sacct_output");
    EXPECT_EQ(r.error().message, message);
  }
}

// --- the plan header: the rules deploy/lib/plan.sh applies, from one table -------------------

TEST(SlurmPlan, HeaderRulesFromTheSharedTable) {
  const auto table = nlohmann::json::parse(
      hdrd::testing::read_file(hdrd::testing::source_dir() / "tests/cluster/plan_header_cases.json"));
  ASSERT_GE(table["cases"].size(), 10u);
  for (const auto& c : table["cases"]) {
    const std::string name = c["name"];
    auto h = parse_plan_header(c["text"].get<std::string>(), "/plans");
    if (c["error"].is_null()) {
      ASSERT_TRUE(h) << name << ": " << h.error().message;
      EXPECT_TRUE(h->work_dir.is_absolute()) << name;
    } else {
      ASSERT_FALSE(h) << name;
      EXPECT_EQ(h.error().message, c["error"].get<std::string>()) << name;
    }
  }
}

TEST(SlurmPlan, RelativeWorkDirIsRelativeToThePlan) {
  auto h = parse_plan_header(R"({"format":"hdrd-sequence-plan","shards":4,"frames":240,"work_dir":"shot.d"})", "/data/plans");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shards, 4u);
  EXPECT_EQ(h->frames, 240u);
  EXPECT_EQ(h->work_dir, fs::path("/data/plans/shot.d"));
  auto missing = read_plan_header("/nonexistent/plan.json");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().message, "plan /nonexistent/plan.json: no such file");
}

// Issue 28.10: a submission keeps its shards as ranges: a 1e6-shard plan is one range, not
// a 4 MB list, and every index is still found in order.
TEST(SlurmShards, RangesHoldEveryIndexInFewBytes) {
  const ShardRanges all = ShardRanges::all(1000000);
  EXPECT_EQ(all.size(), 1000000u);
  EXPECT_LT(all.kept_bytes(), 256u);
  EXPECT_EQ(all.spec(), "0-999999");
  EXPECT_EQ(all.at(0), 0u);
  EXPECT_EQ(all.at(999999), 999999u);
  EXPECT_EQ(all.position(123456), std::optional<std::size_t>(123456));
  EXPECT_FALSE(all.position(1000000));
  const ShardRanges some = ShardRanges::of({9, 5, 1, 2, 3, 9, 12, 13});
  EXPECT_EQ(some.spec(), "1-3,5,9,12-13");
  ASSERT_EQ(some.size(), 7u);
  const std::vector<std::uint32_t> expected{1, 2, 3, 5, 9, 12, 13};
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(some.at(k), expected[k]) << k;
    EXPECT_EQ(some.position(expected[k]), std::optional<std::size_t>(k)) << k;
  }
  for (std::uint32_t missing : {0u, 4u, 6u, 10u, 14u}) EXPECT_FALSE(some.position(missing)) << missing;
  EXPECT_EQ(some.last(), 13u);
}

// --- subprocesses --------------------------------------------------------------------------

ProcessSpec spec_of(std::vector<std::string> argv) {
  ProcessSpec spec;
  spec.argv = std::move(argv);
  return spec;
}

TEST(Subprocess, CollectsOutputAndStatusWithoutAShell) {
  auto r = run_process(spec_of({"sh", "-c", "echo out; echo err >&2; exit 7"}));
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->exit_code, 7);
  EXPECT_EQ(r->out, "out\n");
  EXPECT_EQ(r->err, "err\n");
  // An argument is one argv entry, whatever is in it: no shell splits or expands it.
  auto literal = run_process(spec_of({"printf", "%s|", "a b", "$HOME", "*"}));
  ASSERT_TRUE(literal);
  EXPECT_EQ(literal->out, "a b|$HOME|*|");
}

TEST(Subprocess, SetsEnvironmentAndInheritsOnlyStandardFds) {
  ProcessSpec spec = spec_of({"sh", "-c", "echo \"$HDRD_TEST_VALUE\"; ls /proc/self/fd"});
  spec.env = {{"HDRD_TEST_VALUE", "x=1"}};
  // An fd without O_CLOEXEC, numbered high so that it cannot be the one ls opens itself.
  const int opened = ::open("/dev/null", O_RDONLY);
  const int leaked = ::dup2(opened, 57);
  ::close(opened);
  ASSERT_EQ(leaked, 57);
  auto r = run_process(spec);
  ::close(leaked);
  ASSERT_TRUE(r);
  std::istringstream lines(r->out);
  std::string value, fd;
  std::getline(lines, value);
  EXPECT_EQ(value, "x=1");
  std::vector<int> fds;
  while (std::getline(lines, fd)) fds.push_back(std::stoi(fd));
  // 0-2 and the directory ls reads /proc/self/fd through.
  EXPECT_LE(fds.size(), 4u) << r->out;
  EXPECT_EQ(std::count(fds.begin(), fds.end(), leaked), 0) << "fd " << leaked << " leaked into the child";
}

TEST(Subprocess, TimeoutKillsTheChild) {
  ProcessSpec spec = spec_of({"sleep", "30"});
  spec.timeout = std::chrono::milliseconds(200);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = run_process(spec);
  const auto took = std::chrono::steady_clock::now() - t0;
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, "process.timeout");
  EXPECT_EQ(r.error().message, "sleep did not finish within 200 ms; stopped");
  EXPECT_LT(took, std::chrono::seconds(5));
}

// Issue 28.11: a timeout killed the command but not what it started (a wrapper script's
// sbatch, here a sleep that holds its output pipe): the whole process group goes.
TEST(Subprocess, TimeoutKillsWhatTheChildStarted) {
  hdrd::testing::TempDir dir;
  const std::string pidfile = (dir / "grandchild.pid").string();
  ProcessSpec spec = spec_of({"sh", "-c", "sleep 30 & echo $! > '" + pidfile + "'; wait"});
  spec.timeout = std::chrono::milliseconds(300);
  auto r = run_process(spec);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, "process.timeout");
  const pid_t grandchild = std::stoi(hdrd::testing::read_file(pidfile));
  // Gone, or a zombie its new parent has not reaped yet: not running.
  auto running = [&] {
    std::ifstream stat("/proc/" + std::to_string(grandchild) + "/stat");
    std::string pid, comm, state;
    return stat >> pid >> comm >> state && state != "Z" && state != "X";
  };
  for (int i = 0; i < 200 && running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(running()) << "the child's own child " << grandchild << " is still running";
  if (running()) ::kill(grandchild, SIGKILL);
}

TEST(Subprocess, OutputBeyondTheBoundStopsTheChild) {
  ProcessSpec spec = spec_of({"yes"});
  spec.max_output_bytes = 100000;
  auto r = run_process(spec);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, "process.output_too_large");
  EXPECT_EQ(r.error().message, "yes wrote more than 100000 bytes on stdout; stopped");
}

TEST(Subprocess, MissingProgramIsAnError) {
  auto r = run_process(spec_of({"hdrd-no-such-program"}));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, "process.spawn");
  EXPECT_EQ(r.error().message, "cannot run hdrd-no-such-program: No such file or directory");
  auto none = run_process(spec_of({}));
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, "process.spawn");
}

// --- the client, against recording stand-ins -------------------------------------------------

// A bin dir with sbatch, squeue, sacct and scancel stand-ins: each appends its argv (one
// argument a line, then "--end--") to calls.log; sbatch prints the next line of ids (FAIL:
// exit 1 with sbatch's message); squeue and sacct print squeue.out / sacct.out (with
// squeue.err / sacct.err and their exit status in squeue.rc / sacct.rc).
class FakeSlurm : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(bin());
    const std::string record = "printf '%s\\n' \"$(basename \"$0\")\" \"$@\" --end-- >>" + (dir() / "calls.log").string() + "\n";
    write_file(bin() / "sbatch",
               "#!/bin/sh\n" + record + "n=$(grep -c -- '^--end--$' " + (dir() / "calls.log").string() + ")\n" +
                   "id=$(sed -n \"${n}p\" " + (dir() / "ids").string() + ")\n" +
                   "[ \"$id\" = FAIL ] && { echo 'sbatch: error: Batch job submission failed: Invalid partition name specified' >&2; exit 1; }\n"
                   "echo \"$id\"\n",
               true);
    for (const std::string tool : {"squeue", "sacct"})
      write_file(bin() / tool,
                 "#!/bin/sh\n" + record + "d=" + dir().string() + "\ncat $d/" + tool + ".out 2>/dev/null\ncat $d/" +
                     tool + ".err >&2 2>/dev/null\nexit $(cat $d/" + tool + ".rc 2>/dev/null || echo 0)\n",
                 true);
    write_file(bin() / "scancel", "#!/bin/sh\n" + record, true);
    fs::create_directories(dir() / "plans");
    plan_ = dir() / "plans/shot.json";
    write_file(plan_, R"({"format": "hdrd-sequence-plan", "shards": 3, "frames": 30, "work_dir": "w", "outbase": null})");
  }
  const fs::path& dir() const { return tmp_.path(); }
  fs::path bin() const { return dir() / "bin"; }
  ClusterConfig config() const {
    ClusterConfig c;
    c.scripts_dir = hdrd::testing::source_dir() / "deploy/slurm";
    c.slurm_bin_dir = bin();
    c.hdrd_program = "/opt/hdrd/bin/hdrd";
    c.sbatch_options = {"--partition=render", "--time=60"};
    c.command_timeout = std::chrono::milliseconds(10000);
    return c;
  }
  void ids(const std::string& lines) {
    write_file(dir() / "ids", lines);
    fs::remove(dir() / "calls.log");
  }
  // Each call as "tool arg arg ...".
  std::vector<std::string> calls() const {
    std::vector<std::string> out;
    std::istringstream in(hdrd::testing::read_file(dir() / "calls.log"));
    std::string line, call;
    while (std::getline(in, line)) {
      if (line == "--end--") {
        out.push_back(call);
        call.clear();
      } else {
        call += (call.empty() ? "" : " ") + line;
      }
    }
    return out;
  }
  TempDir tmp_;
  fs::path plan_;
};

TEST_F(FakeSlurm, SubmitsTheArrayThenTheMergeAfterIt) {
  ids("101\n102;cluster1\n");
  Client client(config());
  auto s = client.submit(plan_, dir() / "seq");
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->array_job_id, 101u);
  EXPECT_EQ(s->merge_job_id, 102u);
  EXPECT_EQ(s->shards.spec(), "0-2");
  const std::string scripts = (hdrd::testing::source_dir() / "deploy/slurm").string();
  const std::string work = (dir() / "plans/w").string();
  EXPECT_EQ(calls(), (std::vector<std::string>{
                         "sbatch --parsable --array=0-2 --chdir=" + work + " --partition=render --time=60 " + scripts +
                             "/shard.sbatch " + plan_.string() + " /opt/hdrd/bin/hdrd",
                         "sbatch --parsable --dependency=afterok:101 --chdir=" + work + " --partition=render --time=60 " +
                             scripts + "/merge.sbatch " + plan_.string() + " " + (dir() / "seq").string() +
                             " /opt/hdrd/bin/hdrd"}));
  EXPECT_TRUE(fs::is_directory(work)) << "the work dir is made for the jobs' logs";
}

TEST_F(FakeSlurm, BuildsTheSameSbatchCallsAsSubmitSh) {
  // deploy/slurm/submit.sh and the client both submit plans; they must not drift apart.
  for (const auto& [options, flags] : std::vector<std::pair<SubmitOptions, std::string>>{
           {SubmitOptions{}, ""},
           {SubmitOptions{{4, 1, 2}, 3}, "--shards 1-2,4 --max-parallel 3"}}) {
    write_file(plan_, R"({"format": "hdrd-sequence-plan", "shards": 5, "frames": 30, "work_dir": "w"})");
    ids("7\n8\n");
    ASSERT_TRUE(Client(config()).submit(plan_, dir() / "seq", options));
    const auto from_client = calls();
    ids("7\n8\n");
    const auto r = hdrd::testing::run_command(
        "PATH=" + bin().string() + ":$PATH HDRD_BIN=/opt/hdrd/bin/hdrd " +
        (hdrd::testing::source_dir() / "deploy/slurm/submit.sh").string() + " " + plan_.string() + " " +
        (dir() / "seq").string() + " " + flags + " --partition=render --time=60");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(from_client, calls()) << flags;
  }
}

TEST_F(FakeSlurm, AMergeThatCannotBeSubmittedCancelsTheArray) {
  ids("55\nFAIL\n");
  auto s = Client(config()).submit(plan_, dir() / "seq");
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, "slurm.sbatch");
  EXPECT_EQ(s.error().message,
            "the merge job was not submitted: 'sbatch: error: Batch job submission failed: Invalid partition name "
            "specified'; array job 55 cancelled");
  EXPECT_EQ(calls().back(), "scancel 55");
}

TEST_F(FakeSlurm, RefusesBadPlansAndOptionsBeforeCallingSbatch) {
  ids("1\n2\n");
  Client client(config());
  auto out_of_range = client.submit(plan_, dir() / "seq", SubmitOptions{{0, 3}, std::nullopt});
  ASSERT_FALSE(out_of_range);
  EXPECT_EQ(out_of_range.error().message, "shard 3 is out of range (the plan has 3 shards: 0-2)");
  auto zero = client.submit(plan_, dir() / "seq", SubmitOptions{{}, 0});
  ASSERT_FALSE(zero);
  EXPECT_EQ(zero.error().field, "max_parallel");
  auto no_folder = client.submit(plan_, dir() / "nowhere/seq");
  ASSERT_FALSE(no_folder);
  EXPECT_THAT(no_folder.error().message, HasSubstr("its folder does not exist"));
  write_file(plan_, R"({"format": "hdrd-sequence-plan", "shards": 0, "frames": 1, "work_dir": "w"})");
  auto bad_plan = client.submit(plan_, dir() / "seq");
  ASSERT_FALSE(bad_plan);
  EXPECT_EQ(bad_plan.error().code, "plan.shards");
  EXPECT_TRUE(calls().empty());
  EXPECT_THROW(Client(ClusterConfig{}), HdrdError) << "no scripts_dir";
}

TEST_F(FakeSlurm, ProgressFromSqueue) {
  write_file(dir() / "squeue.out", recorded("squeue-failed-shard.txt"));
  const Submission s{10, 11, ShardRanges::of({0, 1, 2, 3, 4, 5})};
  auto p = Client(config()).progress(s);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->completed, 3u);
  EXPECT_EQ(p->failed, 1u);
  EXPECT_EQ(p->pending, 2u);
  EXPECT_EQ(p->state, JobState::failed);
  ASSERT_TRUE(p->merge);
  EXPECT_EQ(p->merge->reason, "Dependency");
  ASSERT_EQ(p->shards.size(), 6u);
  EXPECT_EQ(*p->shards[3].array_task, 3u);
  EXPECT_EQ(p->shards[3].state, JobState::failed);
  EXPECT_EQ(calls(), (std::vector<std::string>{"squeue --noheader --array --states=all --jobs=10,11 --format=%F|%K|%T|%r"}))
      << "squeue knew every job: no sacct";

  write_file(dir() / "squeue.out", recorded("squeue-throttled-unsplit.txt"));
  auto running = Client(config()).progress(s);
  ASSERT_TRUE(running);
  EXPECT_EQ(running->state, JobState::running);
  EXPECT_EQ(running->running, 2u);
  EXPECT_EQ(running->pending, 4u);
}

TEST_F(FakeSlurm, ProgressFallsBackToSacctForForgottenJobs) {
  write_file(dir() / "squeue.err", recorded("squeue-unknown.err"));
  write_file(dir() / "squeue.rc", "1");
  write_file(dir() / "sacct.out", "10_0|COMPLETED|0:0\n10_1|COMPLETED|0:0\n10_2|COMPLETED|0:0\n11|COMPLETED|0:0\n");
  const Submission s{10, 11, ShardRanges::of({0, 1, 2})};
  auto p = Client(config()).progress(s);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_EQ(p->state, JobState::completed);
  EXPECT_EQ(p->completed, 3u);
  EXPECT_EQ(p->shards[0].exit_code, "0:0");
  EXPECT_EQ(calls().back(), "sacct --noheader --parsable2 --allocations --jobs=10,11 --format=JobID,State,ExitCode");

  // Without accounting, and squeue has forgotten both: nothing to report.
  write_file(dir() / "sacct.out", "");
  write_file(dir() / "sacct.err", recorded("sacct-noacct.err"));
  write_file(dir() / "sacct.rc", "1");
  auto gone = Client(config()).progress(s);
  ASSERT_FALSE(gone);
  EXPECT_EQ(gone.error().code, "slurm.unknown_job");
}

TEST_F(FakeSlurm, ProgressNamesShardsNobodyKnows) {
  write_file(dir() / "squeue.out", "10|2|RUNNING|None\n11|N/A|PENDING|Dependency\n");
  write_file(dir() / "sacct.rc", "1");
  auto p = Client(config()).progress(Submission{10, 11, ShardRanges::of({0, 1, 2})});
  ASSERT_TRUE(p);
  EXPECT_EQ(p->unknown_shards, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_EQ(p->running, 1u);
  EXPECT_EQ(p->state, JobState::running);
}

TEST_F(FakeSlurm, ProgressReportsBrokenOutputAndHungTools) {
  write_file(dir() / "squeue.out", "10|0|RUNNING\n");
  auto broken = Client(config()).progress(Submission{10, 11, ShardRanges::of({0})});
  ASSERT_FALSE(broken);
  EXPECT_EQ(broken.error().code, "slurm.squeue_output");
  write_file(bin() / "squeue", "#!/bin/sh\nexec sleep 30\n", true);
  auto c = config();
  c.command_timeout = std::chrono::milliseconds(300);
  auto hung = Client(c).progress(Submission{10, 11, ShardRanges::of({0})});
  ASSERT_FALSE(hung);
  EXPECT_EQ(hung.error().code, "process.timeout");
}

TEST_F(FakeSlurm, CancelsMergeAndArray) {
  ASSERT_TRUE(Client(config()).cancel(Submission{10, 11, ShardRanges::of({0, 1})}));
  EXPECT_EQ(calls(), (std::vector<std::string>{"scancel 11 10"}));
}

}  // namespace

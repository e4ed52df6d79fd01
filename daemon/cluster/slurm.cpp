#include "daemon/cluster/slurm.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <fstream>
#include <iterator>
#include <sstream>

#include <nlohmann/json.hpp>

#include "daemon/cluster/subprocess.hpp"

namespace hdrd::daemon::slurm {
namespace {

namespace fs = std::filesystem;

// Slurm's MaxArraySize can be at most 4000001 (slurm.conf(5)); a range beyond it is not
// something squeue or sacct can print, so it is a malformed line, not a big array.
constexpr std::uint64_t kMaxArrayTasks = 4000001;

struct StateName {
  std::string_view name;
  JobState state;
};
// Every job state Slurm 22.05 prints (job_state_string, job_state_string_compact's long
// forms). Held and requeued jobs wait; COMPLETING, SUSPENDED and the like are still running
// their program; PREEMPTED without a requeue ended without finishing.
constexpr std::array<StateName, 24> kStates{{
    {"PENDING", JobState::pending},        {"CONFIGURING", JobState::pending},
    {"REQUEUED", JobState::pending},       {"REQUEUE_FED", JobState::pending},
    {"REQUEUE_HOLD", JobState::pending},   {"RESV_DEL_HOLD", JobState::pending},
    {"SPECIAL_EXIT", JobState::pending},   {"RUNNING", JobState::running},
    {"COMPLETING", JobState::running},     {"SUSPENDED", JobState::running},
    {"STOPPED", JobState::running},        {"SIGNALING", JobState::running},
    {"STAGE_OUT", JobState::running},      {"RESIZING", JobState::running},
    {"COMPLETED", JobState::completed},    {"FAILED", JobState::failed},
    {"TIMEOUT", JobState::failed},         {"NODE_FAIL", JobState::failed},
    {"BOOT_FAIL", JobState::failed},       {"DEADLINE", JobState::failed},
    {"OUT_OF_MEMORY", JobState::failed},   {"PREEMPTED", JobState::failed},
    {"CANCELLED", JobState::cancelled},    {"REVOKED", JobState::cancelled},
}};

// Text from another program, made fit for a one-line message: printable ASCII, at most 160
// characters.
std::string quote_text(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, 160)) out += (c >= 0x20 && c < 0x7f) ? c : ' ';
  if (s.size() > 160) out += "...";
  return "'" + out + "'";
}

std::string first_line(std::string_view s) {
  while (!s.empty() && (s.front() == '\n' || s.front() == ' ')) s.remove_prefix(1);
  return std::string(s.substr(0, s.find('\n')));
}

template <class T>
bool parse_uint(std::string_view s, T& value) {
  if (s.empty() || s.size() > 19 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), value);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Splits output into lines: every line ends with '\n' except, optionally, the last; no empty
// lines, no carriage returns.
Result<std::vector<std::string_view>> split_lines(std::string_view out, const std::string& code) {
  std::vector<std::string_view> lines;
  std::size_t start = 0;
  while (start < out.size()) {
    std::size_t end = out.find('\n', start);
    if (end == std::string_view::npos) end = out.size();
    const std::string_view line = out.substr(start, end - start);
    if (line.empty()) return make_error(code, "line " + std::to_string(lines.size() + 1) + " is empty", "output");
    if (line.find('\r') != std::string_view::npos)
      return make_error(code, "line " + std::to_string(lines.size() + 1) + " has a carriage return", "output");
    lines.push_back(line);
    start = end + 1;
  }
  return lines;
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> f;
  std::size_t start = 0;
  for (;;) {
    const std::size_t bar = line.find('|', start);
    f.push_back(line.substr(start, bar == std::string_view::npos ? std::string_view::npos : bar - start));
    if (bar == std::string_view::npos) return f;
    start = bar + 1;
  }
}

Error line_error(const std::string& code, std::size_t line, const std::string& what) {
  return make_error(code, "line " + std::to_string(line) + ": " + what, "output");
}

// An array index expression as squeue (%K) and sacct (JobID after '_') print it: "7",
// "2-5", "0-15:4", "1,3-4%2", optionally in brackets. Appends the indices to `tasks`, at
// most `room` of them (a few bytes of range must not become millions of rows).
Result<void> expand_tasks(std::string_view spec, std::vector<std::uint32_t>& tasks, std::size_t room,
                          const std::string& code, std::size_t line) {
  const bool bracketed = spec.size() >= 2 && spec.front() == '[' && spec.back() == ']';
  if (bracketed) spec = spec.substr(1, spec.size() - 2);
  if (const auto pct = spec.find('%'); pct != std::string_view::npos) {  // a throttle: no tasks of its own
    std::uint32_t limit = 0;
    if (!parse_uint(spec.substr(pct + 1), limit)) return line_error(code, line, "bad array throttle in " + quote_text(spec));
    spec = spec.substr(0, pct);
  }
  if (spec.empty()) return line_error(code, line, "empty array index");
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = spec.find(',', start);
    std::string_view item = spec.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    std::uint64_t step = 1;
    if (const auto colon = item.find(':'); colon != std::string_view::npos) {
      if (!parse_uint(item.substr(colon + 1), step) || step == 0)
        return line_error(code, line, "bad array step in " + quote_text(item));
      item = item.substr(0, colon);
    }
    const auto dash = item.find('-');
    std::uint64_t first = 0, last = 0;
    if (!parse_uint(item.substr(0, dash), first) ||
        (dash != std::string_view::npos ? !parse_uint(item.substr(dash + 1), last) : (last = first, false)))
      return line_error(code, line, "bad array index " + quote_text(item));
    if (first > last || last >= kMaxArrayTasks)
      return line_error(code, line, "array index range " + quote_text(item) + " is backwards or beyond Slurm's limit");
    if (tasks.size() + (last - first) / step >= room)
      return line_error(code, line, "more rows than the " + std::to_string(room) + " expected");
    for (std::uint64_t t = first; t <= last; t += step) tasks.push_back(std::uint32_t(t));
    if (comma == std::string_view::npos) return {};
    start = comma + 1;
  }
}

// State and reason texts: printable ASCII (spaces allowed), no field separator.
bool printable(std::string_view s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return c >= 0x20 && c < 0x7f && c != '|'; });
}

Result<TaskStatus> state_field(std::string_view state, const std::string& code, std::size_t line) {
  TaskStatus t;
  // sacct prints "CANCELLED by UID" for a job a user cancelled.
  if (state.substr(0, 13) == "CANCELLED by ") {
    std::uint64_t uid = 0;
    if (!parse_uint(state.substr(13), uid)) return line_error(code, line, "bad state " + quote_text(state));
    state = "CANCELLED";
  }
  auto s = map_state(state);
  if (!s) return line_error(code, line, s.error().message);
  t.state = *s;
  t.slurm_state = std::string(state);
  return t;
}

void append_tasks(std::vector<TaskStatus>& out, const TaskStatus& proto, const std::vector<std::uint32_t>& tasks) {
  for (std::uint32_t task : tasks) {
    TaskStatus t = proto;
    t.array_task = task;
    out.push_back(std::move(t));
  }
}

Result<ShardRanges> chosen_shards(const PlanHeader& plan, const SubmitOptions& options) {
  if (options.shards.empty()) return ShardRanges::all(plan.shards);
  ShardRanges r = ShardRanges::of(options.shards);
  if (r.last() >= plan.shards)
    return make_error("slurm.options",
                      "shard " + std::to_string(r.last()) + " is out of range (the plan has " + std::to_string(plan.shards) +
                          " shards: 0-" + std::to_string(plan.shards - 1) + ")",
                      "shards");
  return r;
}

}  // namespace

ShardRanges ShardRanges::all(std::uint32_t shards) {
  ShardRanges r;
  if (shards > 0) r.add(0, shards - 1);
  return r;
}

ShardRanges ShardRanges::of(std::vector<std::uint32_t> indices) {
  std::sort(indices.begin(), indices.end());
  indices.erase(std::unique(indices.begin(), indices.end()), indices.end());
  ShardRanges r;
  for (std::size_t i = 0; i < indices.size();) {
    std::size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    r.add(indices[i], indices[j]);
    i = j + 1;
  }
  return r;
}

void ShardRanges::add(std::uint32_t first, std::uint32_t last) {
  runs_.emplace_back(first, last);
  before_.push_back(size_);
  size_ += std::size_t(last - first) + 1;
}

std::uint32_t ShardRanges::at(std::size_t k) const {
  const auto it = std::upper_bound(before_.begin(), before_.end(), k) - 1;  // the run holding the k-th
  const std::size_t run = std::size_t(it - before_.begin());
  return runs_[run].first + std::uint32_t(k - *it);
}

std::optional<std::size_t> ShardRanges::position(std::uint32_t shard) const {
  const auto it = std::upper_bound(runs_.begin(), runs_.end(), shard,
                                   [](std::uint32_t v, const auto& run) { return v < run.first; });
  if (it == runs_.begin()) return std::nullopt;
  const std::size_t run = std::size_t(it - runs_.begin()) - 1;
  if (shard > runs_[run].second) return std::nullopt;
  return before_[run] + (shard - runs_[run].first);
}

std::string ShardRanges::spec() const {
  std::string spec;
  for (const auto& [first, last] : runs_) {
    if (!spec.empty()) spec += ',';
    spec += std::to_string(first);
    if (last > first) spec += "-" + std::to_string(last);
  }
  return spec;
}

std::string_view to_string(JobState s) {
  switch (s) {
    case JobState::pending: return "pending";
    case JobState::running: return "running";
    case JobState::completed: return "completed";
    case JobState::failed: return "failed";
    case JobState::cancelled: return "cancelled";
  }
  return "pending";
}

Result<JobState> map_state(std::string_view slurm_state) {
  for (const auto& s : kStates)
    if (s.name == slurm_state) return s.state;
  return make_error("slurm.state", "unknown Slurm job state " + quote_text(slurm_state), "state");
}

Result<std::uint64_t> parse_sbatch_parsable(std::string_view out) {
  const std::string code = "slurm.sbatch_output";
  if (!out.empty() && out.back() == '\n') out.remove_suffix(1);
  const std::string_view id_text = out.substr(0, out.find(';'));
  std::uint64_t id = 0;
  if (!parse_uint(id_text, id) || id == 0)
    return make_error(code, "sbatch printed " + quote_text(out) + ", expected a job id", "output");
  if (id_text.size() < out.size()) {  // ";CLUSTER"
    const std::string_view cluster = out.substr(id_text.size() + 1);
    const bool ok = !cluster.empty() && std::all_of(cluster.begin(), cluster.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
    if (!ok) return make_error(code, "sbatch printed " + quote_text(out) + ", expected ID;CLUSTER", "output");
  }
  return id;
}

Result<std::vector<TaskStatus>> parse_squeue(std::string_view out, std::size_t max_rows) {
  const std::string code = "slurm.squeue_output";
  auto lines = split_lines(out, code);
  if (!lines) return lines.error();
  std::vector<TaskStatus> result;
  for (std::size_t n = 0; n < lines->size(); ++n) {
    const auto f = split_fields((*lines)[n]);
    if (f.size() != 4) return line_error(code, n + 1, "expected 4 fields (job|task|state|reason), got " + std::to_string(f.size()));
    auto t = state_field(f[2], code, n + 1);
    if (!t) return t.error();
    if (!parse_uint(f[0], t->job_id) || t->job_id == 0) return line_error(code, n + 1, "bad job id " + quote_text(f[0]));
    if (!printable(f[3])) return line_error(code, n + 1, "bad reason " + quote_text(f[3]));
    t->reason = std::string(f[3]);
    if (result.size() >= max_rows) return line_error(code, n + 1, "more rows than the " + std::to_string(max_rows) + " expected");
    if (f[1] == "N/A") {
      result.push_back(std::move(*t));
      continue;
    }
    std::vector<std::uint32_t> tasks;
    if (auto r = expand_tasks(f[1], tasks, max_rows - result.size(), code, n + 1); !r) return r.error();
    append_tasks(result, *t, tasks);
  }
  return result;
}

Result<std::vector<TaskStatus>> parse_sacct(std::string_view out, std::size_t max_rows) {
  const std::string code = "slurm.sacct_output";
  auto lines = split_lines(out, code);
  if (!lines) return lines.error();
  std::vector<TaskStatus> result;
  for (std::size_t n = 0; n < lines->size(); ++n) {
    const auto f = split_fields((*lines)[n]);
    if (f.size() != 3) return line_error(code, n + 1, "expected 3 fields (jobid|state|exitcode), got " + std::to_string(f.size()));
    auto t = state_field(f[1], code, n + 1);
    if (!t) return t.error();
    const auto colon = f[2].find(':');
    int status = 0, signal = 0;
    if (colon == std::string_view::npos || !parse_uint(f[2].substr(0, colon), status) ||
        !parse_uint(f[2].substr(colon + 1), signal))
      return line_error(code, n + 1, "bad exit code " + quote_text(f[2]));
    t->exit_code = std::string(f[2]);
    const auto underscore = f[0].find('_');
    if (!parse_uint(f[0].substr(0, underscore), t->job_id) || t->job_id == 0)
      return line_error(code, n + 1, "bad job id " + quote_text(f[0]));
    if (result.size() >= max_rows) return line_error(code, n + 1, "more rows than the " + std::to_string(max_rows) + " expected");
    if (underscore == std::string_view::npos) {
      result.push_back(std::move(*t));
      continue;
    }
    std::vector<std::uint32_t> tasks;
    if (auto r = expand_tasks(f[0].substr(underscore + 1), tasks, max_rows - result.size(), code, n + 1); !r)
      return r.error();
    append_tasks(result, *t, tasks);
  }
  return result;
}

Result<PlanHeader> parse_plan_header(std::string_view text, const fs::path& plan_folder) {
  const auto doc = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (doc.is_discarded()) return make_error("plan.syntax", "not a JSON file");
  if (!doc.is_object()) return make_error("plan.syntax", "not a JSON object");
  auto shown = [&](const char* key) {
    return doc.contains(key) ? doc[key].dump(-1, ' ', true, nlohmann::json::error_handler_t::replace) : "null";
  };
  if (!doc.contains("format") || doc["format"] != "hdrd-sequence-plan")
    return make_error("plan.format", "format is " + shown("format") + ", expected \"hdrd-sequence-plan\"", "format");
  PlanHeader h;
  const auto& shards = doc.contains("shards") ? doc["shards"] : nlohmann::json();
  if (!shards.is_number_integer() || shards.get<std::int64_t>() < 1 || shards.get<std::int64_t>() > kMaxShards)
    return make_error("plan.shards", "shards is " + shown("shards") + ", expected an integer from 1 to " +
                                         std::to_string(kMaxShards), "shards");
  h.shards = shards.get<std::uint32_t>();
  const auto& frames = doc.contains("frames") ? doc["frames"] : nlohmann::json();
  if (!frames.is_number_integer() || frames.get<std::int64_t>() < 1)
    return make_error("plan.frames", "frames is " + shown("frames") + ", expected an integer >= 1", "frames");
  h.frames = frames.get<std::uint64_t>();
  const auto& work = doc.contains("work_dir") ? doc["work_dir"] : nlohmann::json();
  if (!work.is_string() || work.get<std::string>().empty() ||
      work.get<std::string>().find_first_of(std::string_view("\n\0", 2)) != std::string::npos)
    return make_error("plan.work_dir", "work_dir is " + shown("work_dir") + ", expected a path", "work_dir");
  h.work_dir = fs::path(work.get<std::string>());
  if (h.work_dir.is_relative()) h.work_dir = plan_folder / h.work_dir;
  return h;
}

Result<PlanHeader> read_plan_header(const fs::path& plan_path, const io::InputFiles& files) {
  auto text = files.read(plan_path, io::kMaxInputFileBytes);
  if (!text) {
    Error e = io::reader_error(text.error(), "plan.missing", "plan.missing", "plan");
    e.message = "plan " + plan_path.string() + ": " + (e.code == "plan.missing" ? "no such file" : e.message);
    return e;
  }
  auto h = parse_plan_header(*text, fs::absolute(plan_path).parent_path());
  if (!h) return make_error(h.error().code, "plan " + plan_path.string() + ": " + h.error().message, h.error().field);
  return h;
}

SbatchCommands sbatch_commands(const ClusterConfig& config, const fs::path& plan_path, const PlanHeader& plan,
                               const fs::path& outbase, const SubmitOptions& options, std::uint64_t array_job_id) {
  std::string spec = (options.shards.empty() ? ShardRanges::all(plan.shards) : ShardRanges::of(options.shards)).spec();
  if (options.max_parallel) spec += "%" + std::to_string(*options.max_parallel);
  const std::string chdir = "--chdir=" + plan.work_dir.string();
  SbatchCommands c;
  c.array = {"sbatch", "--parsable", "--array=" + spec, chdir};
  c.merge = {"sbatch", "--parsable", "--dependency=afterok:" + std::to_string(array_job_id), chdir};
  for (auto* argv : {&c.array, &c.merge}) argv->insert(argv->end(), config.sbatch_options.begin(), config.sbatch_options.end());
  c.array.insert(c.array.end(), {(config.scripts_dir / "shard.sbatch").string(), plan_path.string(), config.hdrd_program});
  c.merge.insert(c.merge.end(), {(config.scripts_dir / "merge.sbatch").string(), plan_path.string(), outbase.string(),
                                 config.hdrd_program});
  return c;
}

// --- Client ---------------------------------------------------------------------------------

struct Client::Output {
  int exit_code = -1;
  std::string out, err;
};

Client::Client(ClusterConfig config) : config_(std::move(config)) {
  for (const char* script : {"shard.sbatch", "merge.sbatch"})
    if (!fs::is_regular_file(config_.scripts_dir / script))
      throw HdrdError(make_error("slurm.config", "scripts_dir " + config_.scripts_dir.string() + " has no " + script +
                                                     " (it is deploy/slurm in the source tree)", "scripts_dir"));
}

Result<Client::Output> Client::run(const std::string& program, std::vector<std::string> args) const {
  ProcessSpec spec;
  spec.argv.push_back(config_.slurm_bin_dir.empty() ? program : (config_.slurm_bin_dir / program).string());
  spec.argv.insert(spec.argv.end(), std::make_move_iterator(args.begin()), std::make_move_iterator(args.end()));
  if (!config_.slurm_conf.empty()) spec.env.emplace_back("SLURM_CONF", config_.slurm_conf.string());
  spec.timeout = config_.command_timeout;
  spec.max_output_bytes = config_.max_output_bytes;
  auto r = run_process(spec);
  if (!r) return r.error();
  return Output{r->signal ? -1 : r->exit_code, std::move(r->out), std::move(r->err)};
}

Result<Submission> Client::submit(const fs::path& plan_arg, const fs::path& outbase_arg, const SubmitOptions& options,
                                  const io::InputFiles& files) const {
  auto plan = read_plan_header(plan_arg, files);
  if (!plan) return plan.error();
  auto shards = chosen_shards(*plan, options);
  if (!shards) return shards.error();
  if (options.max_parallel && *options.max_parallel == 0)
    return make_error("slurm.options", "max_parallel is 0, expected an integer >= 1", "max_parallel");
  const fs::path plan_path = fs::absolute(plan_arg), outbase = fs::absolute(outbase_arg);
  std::error_code ec;
  if (outbase.filename().empty() || !fs::is_directory(outbase.parent_path(), ec))
    return make_error("slurm.options", "outbase " + outbase.string() + ": its folder does not exist", "outbase");
  fs::create_directories(plan->work_dir, ec);
  if (!fs::is_directory(plan->work_dir, ec))
    return make_error("slurm.options", "work dir " + plan->work_dir.string() + " cannot be created", "work_dir");

  const SubmitOptions& chosen = options;
  auto sbatch = [&](std::vector<std::string> argv, const char* what) -> Result<std::uint64_t> {
    argv.erase(argv.begin());
    auto r = run("sbatch", std::move(argv));
    if (!r) return r.error();
    if (r->exit_code != 0)
      return make_error("slurm.sbatch", std::string("the ") + what + " was not submitted: " + quote_text(first_line(r->err)), "sbatch");
    return parse_sbatch_parsable(r->out);
  };
  auto array_id = sbatch(sbatch_commands(config_, plan_path, *plan, outbase, chosen, 0).array, "shards' array job");
  if (!array_id) return array_id.error();
  auto merge_id = sbatch(sbatch_commands(config_, plan_path, *plan, outbase, chosen, *array_id).merge, "merge job");
  if (!merge_id) {
    (void)run("scancel", {std::to_string(*array_id)});
    const Error& e = merge_id.error();
    return make_error(e.code, e.message + "; array job " + std::to_string(*array_id) + " cancelled", e.field);
  }
  return Submission{*array_id, *merge_id, std::move(*shards)};
}

namespace {

// Keeps the statuses that belong to the submission: its array's submitted tasks and the merge.
void collect(const std::vector<TaskStatus>& rows, const Submission& s, std::vector<std::optional<TaskStatus>>& shards,
             std::optional<TaskStatus>& merge) {
  for (const auto& t : rows) {
    if (t.job_id == s.merge_job_id && !t.array_task && !merge) merge = t;
    if (t.job_id != s.array_job_id || !t.array_task) continue;
    if (const auto k = s.shards.position(*t.array_task); k && !shards[*k]) shards[*k] = t;
  }
}

JobState overall(const Progress& p) {
  const auto merge = p.merge ? std::optional(p.merge->state) : std::nullopt;
  if (merge == JobState::completed) return JobState::completed;
  if (p.failed > 0 || merge == JobState::failed) return JobState::failed;
  if (p.cancelled > 0 || merge == JobState::cancelled) return JobState::cancelled;
  if (p.running > 0 || p.completed > 0 || merge == JobState::running) return JobState::running;
  return JobState::pending;
}

}  // namespace

Result<Progress> Client::progress(const Submission& s) const {
  const std::string jobs = "--jobs=" + std::to_string(s.array_job_id) + "," + std::to_string(s.merge_job_id);
  std::vector<std::optional<TaskStatus>> shards(s.shards.size());
  std::optional<TaskStatus> merge;
  auto q = run("squeue", {"--noheader", "--array", "--states=all", jobs, "--format=" + std::string(kSqueueFormat)});
  if (!q) return q.error();
  // squeue exits 1 with "Invalid job id specified" when it knows none of the jobs any more.
  if (q->exit_code != 0 && q->err.find("Invalid job id specified") == std::string::npos)
    return make_error("slurm.squeue", "squeue failed: " + quote_text(first_line(q->err)), "squeue");
  if (q->exit_code == 0) {
    auto rows = parse_squeue(q->out, s.shards.size() + 1);
    if (!rows) return rows.error();
    collect(*rows, s, shards, merge);
  }
  const bool complete = merge && std::all_of(shards.begin(), shards.end(), [](const auto& t) { return t.has_value(); });
  if (!complete) {  // what squeue has forgotten, from accounting (when the cluster keeps it)
    auto a = run("sacct", {"--noheader", "--parsable2", "--allocations", jobs, "--format=" + std::string(kSacctFormat)});
    if (!a && a.error().code != "process.spawn") return a.error();
    if (a && a->exit_code == 0) {
      auto rows = parse_sacct(a->out, s.shards.size() + 1);
      if (!rows) return rows.error();
      collect(*rows, s, shards, merge);
    }
  }
  Progress p;
  p.merge = merge;
  for (std::size_t i = 0; i < shards.size(); ++i) {
    if (!shards[i]) {
      p.unknown_shards.push_back(s.shards.at(i));
      continue;
    }
    switch (shards[i]->state) {
      case JobState::pending: ++p.pending; break;
      case JobState::running: ++p.running; break;
      case JobState::completed: ++p.completed; break;
      case JobState::failed: ++p.failed; break;
      case JobState::cancelled: ++p.cancelled; break;
    }
    p.shards.push_back(std::move(*shards[i]));
  }
  if (!p.merge && p.shards.empty())
    return make_error("slurm.unknown_job",
                      "Slurm knows neither job " + std::to_string(s.array_job_id) + " nor " +
                          std::to_string(s.merge_job_id) + " (ended before its MinJobAge, and no accounting)",
                      "job");
  p.state = overall(p);
  return p;
}

Result<void> Client::cancel(const Submission& s) const {
  auto r = run("scancel", {std::to_string(s.merge_job_id), std::to_string(s.array_job_id)});
  if (!r) return r.error();
  // Jobs that have already ended are not an error: there is nothing left to cancel.
  if (r->exit_code != 0 && r->err.find("already completing or completed") == std::string::npos &&
      r->err.find("Invalid job id specified") == std::string::npos)
    return make_error("slurm.scancel", "scancel failed: " + quote_text(first_line(r->err)), "scancel");
  return {};
}

}  // namespace hdrd::daemon::slurm

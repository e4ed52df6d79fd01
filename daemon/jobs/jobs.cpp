#include "daemon/jobs/jobs.hpp"

#include <fcntl.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <random>

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "shading/renderer.hpp"

namespace fs = std::filesystem;

namespace hdrd::daemon {

using Clock = std::chrono::steady_clock;
using SystemClock = std::chrono::system_clock;

std::string_view to_string(JobState s) {
  switch (s) {
    case JobState::queued: return "queued";
    case JobState::running: return "running";
    case JobState::done: return "done";
    case JobState::failed: return "failed";
    case JobState::cancelled: return "cancelled";
  }
  return "unknown";
}

struct JobRegistry::Job {
  std::string id;
  SequenceSpec spec;
  std::string source;  // spec.request's, kept when the request goes
  JobState state = JobState::queued;
  job::SequenceProgress progress;
  std::optional<Error> error;
  std::map<std::string, std::string> files;
  std::map<std::string, io::FileIdentity> identities;
  SystemClock::time_point created = SystemClock::now();
  std::optional<SystemClock::time_point> started, finished;
  std::optional<Clock::time_point> deadline;
  bool files_removed = false;
  std::string superseded_by;
  std::atomic<bool> cancel{false};
  std::vector<std::function<void(std::optional<Result<JobInfo>>)>> on_final;  // DELETEs waiting
};

namespace {

// A final job keeps what GET /v1/jobs reports and nothing of its request: the request (a
// decoded ui.png_base64, an inline scene, every setting's value) goes when the job ends.
// Issue 28.10: each of the [sequences] history jobs kept its request, a 7.8 MB upload +7.5 MB.
void release_request(SequenceSpec& spec) {
  job::FrameRequest empty;
  empty.source = spec.request.source;
  empty.sequence = spec.request.sequence;
  std::swap(spec.request, empty);  // `empty` (the old request) is freed here
}

// 16 hex digits, unguessable: a job id is not a capability, but ids that count up would
// tell one client how many jobs others ran.
std::string new_job_id() {
  static std::mutex mu;
  static std::mt19937_64 rng{std::random_device{}()};
  std::lock_guard lock(mu);
  return fmt::format("{:016x}", rng());
}

std::string iso8601(SystemClock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count() % 1000;
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", fmt::gmtime(SystemClock::to_time_t(t)), ms);
}

// What each file a finished job wrote is (device, inode, size), taken without following a
// link as soon as run_sequence has renamed it into place.
std::map<std::string, io::FileIdentity> identities_of(const std::map<std::string, std::string>& files) {
  std::map<std::string, io::FileIdentity> out;
  for (const auto& [kind, path] : files) {
    if (kind.rfind("frames.", 0) == 0) continue;  // patterns, not files
    io::UniqueFd fd(::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
    if (!fd) continue;  // not served: GET answers 410
    if (auto id = io::identity_of(fd.get(), path); id) out.emplace(kind, *id);
  }
  return out;
}

}  // namespace

nlohmann::json JobInfo::to_json() const {
  const std::string self = "/v1/jobs/" + id;
  nlohmann::json j = {{"id", id},
                      {"name", name},
                      {"source", source},
                      {"state", to_string(state)},
                      {"frames_done", frames_done},
                      {"frames_total", frames_total},
                      {"fps", fps},
                      {"eta_s", eta_s},
                      {"created_at", iso8601(created)},
                      {"memory_estimate_bytes", memory_bytes},
                      {"files", files},
                      {"links", {{"self", self}, {"result", self + "/result"}, {"sidecar", self + "/sidecar"}}}};
  if (started) j["started_at"] = iso8601(*started);
  if (finished) j["finished_at"] = iso8601(*finished);
  if (started)
    j["elapsed_s"] = std::chrono::duration<double>((finished ? *finished : SystemClock::now()) - *started).count();
  if (error) {
    j["error"] = {{"code", error->code}, {"message", one_line(error->message)}};
    if (!error->field.empty()) j["error"]["field"] = error->field;
  }
  if (files_removed) j["files_removed"] = true;
  if (!superseded_by.empty()) j["superseded_by"] = superseded_by;
  return j;
}

void remove_sequence_files(const std::map<std::string, std::string>& files, int frames) {
  std::error_code ec;
  for (const auto& [kind, path] : files) {
    if (kind.rfind("frames.", 0) != 0) {
      fs::remove(path, ec);
      continue;
    }
    const auto at = path.rfind("%05d");  // job/sequence.cpp names frames OUTBASE.%05d.EXT
    if (at == std::string::npos) continue;
    for (int i = 0; i < frames; ++i)
      fs::remove(path.substr(0, at) + fmt::format("{:05d}", i) + path.substr(at + 4), ec);
  }
}

JobRegistry::JobRegistry(JobRegistryOptions options) : options_(std::move(options)) {
  for (int i = 0; i < std::max(1, options_.max_running); ++i) threads_.emplace_back([this] { worker_loop(); });
}

JobRegistry::~JobRegistry() { shutdown(); }

std::uint64_t JobRegistry::kept_bytes(const Job& j) {
  constexpr std::uint64_t kNode = 64;  // a map node or a heap block's overhead, about
  std::uint64_t n = sizeof(Job) + j.id.capacity() + j.source.capacity() + j.spec.name.capacity() +
                    j.spec.outbase.native().capacity() + j.superseded_by.capacity();
  for (const auto& [kind, path] : j.files) n += kNode + kind.capacity() + path.capacity();
  if (j.error) n += j.error->code.capacity() + j.error->message.capacity() + j.error->field.capacity();
  n += j.spec.request.ui_png.capacity() + j.spec.request.scene.inline_scene.size() * kNode;
  for (const auto& [path, value] : j.spec.request.values)
    n += kNode + path.capacity() + (value.is_string() ? value.get_ref<const std::string&>().capacity() : 16);
  return n;
}

std::uint64_t JobRegistry::kept_bytes_locked() const {
  std::uint64_t n = 0;
  for (const auto& j : order_)
    if (is_final(j->state)) n += kept_bytes(*j);
  return n;
}

JobInfo JobRegistry::info_of(const Job& job) {
  JobInfo i;
  i.id = job.id;
  i.name = job.spec.name;
  i.source = job.source;
  i.state = job.state;
  i.frames_done = job.progress.frames_done;
  // 0 in the spec: a render's animation decides, known once its first frame is made.
  i.frames_total = job.spec.frames_total > 0 ? job.spec.frames_total : job.progress.frames_total;
  i.fps = job.progress.fps;
  i.eta_s = job.state == JobState::running ? job.progress.eta_s : 0;
  i.error = job.error;
  i.files = job.files;
  i.identities = job.identities;
  i.created = job.created;
  i.started = job.started;
  i.finished = job.finished;
  i.memory_bytes = job.spec.memory_bytes;
  i.files_removed = job.files_removed;
  i.superseded_by = job.superseded_by;
  return i;
}

Result<JobInfo> JobRegistry::submit(SequenceSpec spec) {
  std::lock_guard lock(mu_);
  if (stopping_) return make_error("server.draining", "the daemon is shutting down");
  const int idle_workers = std::max(0, options_.max_running - running_);
  if (static_cast<int>(queue_.size()) >= std::max(0, options_.max_queued) + idle_workers)
    return make_error("queue.full", fmt::format("{} sequence jobs are waiting already ([sequences] max_queued)", queue_.size()));
  if (spec.memory_bytes > options_.memory_budget_bytes)
    return make_error("request.memory",
                      fmt::format("the sequence needs about {} MiB at once, more than the daemon's budget of {} MiB",
                                  spec.memory_bytes >> 20, options_.memory_budget_bytes >> 20));
  if (memory_in_flight_ + kept_bytes_locked() + spec.memory_bytes > options_.memory_budget_bytes)
    return make_error("queue.memory", fmt::format("the memory budget is taken by other sequences ({} of {} MiB)",
                                                  memory_in_flight_ >> 20, options_.memory_budget_bytes >> 20));
  std::shared_ptr<Job> same_name;
  for (const auto& j : order_)
    if (j->spec.name == spec.name && !j->files_removed && j->superseded_by.empty()) {
      if (!is_final(j->state))
        return make_error("job.conflict", fmt::format("name: job {} is writing '{}' already", j->id, spec.name), "name");
      same_name = j;
    }
  auto job = std::make_shared<Job>();
  do job->id = new_job_id();
  while (jobs_.count(job->id));
  job->spec = std::move(spec);
  job->source = std::string(job::to_string(job->spec.request.source));
  if (same_name) {  // the same owner: the new job supersedes it, and every file it wrote goes now
    remove_sequence_files(same_name->files, same_name->progress.frames_done);
    same_name->superseded_by = job->id;
    same_name->files.clear();
    same_name->identities.clear();
  }
  memory_in_flight_ += job->spec.memory_bytes;
  jobs_.emplace(job->id, job);
  order_.push_back(job);
  queue_.push_back(job);
  cv_.notify_one();
  spdlog::info("sequence job {} ({}): {} frames into {}, estimate {} MiB", job->id, job->spec.name,
               job->spec.frames_total, job->spec.outbase.string(), job->spec.memory_bytes >> 20);
  return info_of(*job);
}

std::optional<JobInfo> JobRegistry::get(std::string_view id) const {
  std::lock_guard lock(mu_);
  auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return info_of(*it->second);
}

std::vector<JobInfo> JobRegistry::list() const {
  std::lock_guard lock(mu_);
  std::vector<JobInfo> out;
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) out.push_back(info_of(**it));
  return out;
}

void JobRegistry::remove(std::string_view id, std::function<void(std::optional<Result<JobInfo>>)> done) {
  std::shared_ptr<Job> job;
  {
    std::lock_guard lock(mu_);
    auto it = jobs_.find(id);
    if (it == jobs_.end()) return done(std::nullopt);
    job = it->second;
    if (job->state == JobState::running) {  // the worker answers when run_sequence has stopped
      job->cancel = true;
      job->on_final.push_back(std::move(done));
      return;
    }
    if (job->state == JobState::queued) {
      queue_.erase(std::remove(queue_.begin(), queue_.end(), job), queue_.end());
      memory_in_flight_ -= job->spec.memory_bytes;
      job->state = JobState::cancelled;
      job->error = make_error("request.cancelled", "cancelled before it started (DELETE)");
      job->finished = SystemClock::now();
      release_request(job->spec);
    } else if (!job->files_removed && job->superseded_by.empty()) {
      remove_sequence_files(job->files, job->progress.frames_done);
      job->files.clear();
      job->files_removed = true;
    }
  }
  spdlog::info("sequence job {}: deleted ({})", job->id, to_string(job->state));
  std::lock_guard lock(mu_);
  done(info_of(*job));
}

void JobRegistry::shutdown() {
  std::vector<std::shared_ptr<Job>> dropped;
  {
    std::lock_guard lock(mu_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
    for (auto& j : queue_) dropped.push_back(j);
    queue_.clear();
    for (auto& [id, j] : jobs_) j->cancel = true;
  }
  cv_.notify_all();
  for (auto& j : dropped) finish(j, JobState::cancelled, make_error("server.draining", "the daemon shut down before it started"));
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

void JobRegistry::set_limits(int max_queued, int history, std::uint64_t memory_budget_bytes) {
  std::lock_guard lock(mu_);
  options_.max_queued = max_queued;
  options_.history = history;
  options_.memory_budget_bytes = memory_budget_bytes;
  trim_history();
}

JobRegistry::Stats JobRegistry::stats() const {
  std::lock_guard lock(mu_);
  Stats s;
  s.queued = static_cast<int>(queue_.size());
  s.running = running_;
  s.finished = static_cast<int>(order_.size()) - s.queued - s.running;
  s.memory_in_flight_bytes = memory_in_flight_;
  s.memory_kept_bytes = kept_bytes_locked();
  return s;
}

void JobRegistry::worker_loop() {
  std::unique_ptr<shading::Renderer> renderer;  // this thread's: a GL context is bound to its thread
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = queue_.front();
      queue_.pop_front();
      job->state = JobState::running;
      job->started = SystemClock::now();
      if (job->spec.timeout_s) job->deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                                  std::chrono::duration<double>(*job->spec.timeout_s));
      ++running_;
    }
    run(job, renderer);
  }
}

void JobRegistry::run(const std::shared_ptr<Job>& self, std::unique_ptr<shading::Renderer>& renderer) {
  Job& job = *self;
  if (job.spec.request.source == job::Source::render && !renderer) {
    const auto backend = shading::parse_backend(options_.backend).value_or(shading::Backend::automatic);
    auto made = shading::Renderer::create(backend);
    if (!made) {
      Error e = made.error();
      e.message = "no renderer for sequence jobs: " + e.message;
      e.code = "renderer.unavailable";
      return finish(self, JobState::failed, e);
    }
    renderer = std::move(*made);
  }
  job::SequenceOptions so;
  so.job = job.spec.options;
  so.queue_depth = options_.queue_depth;
  so.job.should_stop = [&job] { return job.cancel.load() || (job.deadline && Clock::now() > *job.deadline); };
  so.progress = [this, &job](const job::SequenceProgress& p) {
    std::lock_guard lock(mu_);
    job.progress = p;
  };
  auto result = job::run_sequence(job.spec.request, job.spec.outbase, so, renderer.get());
  if (renderer) renderer->release_frame_targets();
  ::malloc_trim(0);  // a sequence's frames were large and many: hand the free memory back
  if (result) {
    auto identities = identities_of(result->files);
    {
      std::lock_guard lock(mu_);
      job.files = result->files;
      job.identities = std::move(identities);
      job.progress.frames_done = result->frames;
    }
    return finish(self, JobState::done, std::nullopt);
  }
  if (job.cancel.load()) return finish(self, JobState::cancelled, make_error("request.cancelled", "cancelled (DELETE or shutdown)"));
  if (job.deadline && Clock::now() > *job.deadline)
    return finish(self, JobState::failed,
                  make_error("request.timeout", fmt::format("the job ran past its timeout_s of {:g} s", *job.spec.timeout_s)));
  finish(self, JobState::failed, result.error());
}

void JobRegistry::finish(const std::shared_ptr<Job>& job, JobState state, std::optional<Error> error) {
  std::vector<std::function<void(std::optional<Result<JobInfo>>)>> waiting;
  JobInfo info;
  {
    std::lock_guard lock(mu_);
    if (job->state == JobState::running) --running_;
    if (!is_final(job->state)) memory_in_flight_ -= job->spec.memory_bytes;
    job->state = state;
    job->error = std::move(error);
    job->finished = SystemClock::now();
    release_request(job->spec);
    // A finished job's fps is its average over the run, frames_done / elapsed_s (docs/api.md),
    // not the last progress report's rate, which leaves out the set-up and the final mux.
    if (job->started) {
      const double s = std::chrono::duration<double>(*job->finished - *job->started).count();
      job->progress.fps = s > 0 ? job->progress.frames_done / s : 0;
    }
    waiting.swap(job->on_final);
    if (state == JobState::done && !waiting.empty()) {  // a DELETE came as the last frame was written
      remove_sequence_files(job->files, job->progress.frames_done);
      job->files.clear();
      job->files_removed = true;
    }
    info = info_of(*job);
    trim_history();
  }
  if (state == JobState::done)
    spdlog::info("sequence job {} ({}): done, {} frames at {:.1f} fps", info.id, info.name, info.frames_done, info.fps);
  else
    spdlog::info("sequence job {} ({}): {}: {}", info.id, info.name, to_string(state), info.error ? info.error->message : "");
  for (auto& w : waiting) w(info);
}

void JobRegistry::trim_history() {
  int finished = 0;
  for (const auto& j : order_) finished += is_final(j->state) ? 1 : 0;
  for (auto it = order_.begin(); it != order_.end() && finished > options_.history;) {
    if (!is_final((*it)->state)) {
      ++it;
      continue;
    }
    jobs_.erase((*it)->id);  // its files stay in the dump directory
    it = order_.erase(it);
    --finished;
  }
}

}  // namespace hdrd::daemon

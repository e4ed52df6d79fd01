#include "daemon/jobs/scheduler.hpp"

#include <malloc.h>

#include <algorithm>

#include <spdlog/spdlog.h>

#include "daemon/jobs/memory.hpp"

namespace hdrd::daemon {

struct Job {
  JobSpec spec;
  bool needs_renderer = false;
  std::vector<std::shared_ptr<Waiter>> waiters;
  std::atomic<bool> cancelled{false};
  bool started = false;   // a worker has taken it
  bool memory_released = false;
};

namespace {

std::shared_ptr<const Reply> error_reply(std::string code, std::string message) {
  return std::make_shared<const Reply>(Reply::error(make_error(std::move(code), std::move(message))));
}

// Runs a stage; any exception becomes an "internal" error reply rather than a dead thread.
template <class F>
auto guarded(F&& f) -> std::optional<decltype(f())> {
  try {
    return f();
  } catch (const HdrdError& e) {
    spdlog::error("job stage failed: {}", e.what());
  } catch (const std::exception& e) {
    spdlog::error("job stage threw: {}", e.what());
  } catch (...) {
    spdlog::error("job stage threw a non-standard exception");
  }
  return std::nullopt;
}

}  // namespace

Clock::time_point deadline_after(Clock::time_point start, double seconds) {
  // steady_clock counts nanoseconds in 64 bits: about 292 years. Anything beyond a year
  // is "never" for a request, and must not wrap around.
  constexpr double kMaxSeconds = 365.0 * 86400.0;
  if (!(seconds > 0)) return start;
  const double s = std::min(seconds, kMaxSeconds);
  return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

Scheduler::Scheduler(SchedulerOptions options, RenderResourceFactory factory)
    : options_(options), factory_(std::move(factory)) {
  worker_info_.resize(std::size_t(options_.render_workers), nlohmann::json::object());
}

Scheduler::~Scheduler() { drain_and_stop(std::chrono::seconds(0)); }

void Scheduler::start() {
  for (int i = 0; i < options_.render_workers; ++i) threads_.emplace_back([this, i] { render_loop(i); });
  for (int i = 0; i < options_.encode_threads; ++i) threads_.emplace_back([this] { encode_loop(); });
  threads_.emplace_back([this] { trim_loop(); });
  std::unique_lock lock(mu_);
  ready_cv_.wait(lock, [&] { return started_workers_ == options_.render_workers; });
}

Result<std::shared_ptr<Waiter>> Scheduler::submit(JobSpec spec,
                                                  std::function<void(std::shared_ptr<const Reply>, bool)> deliver,
                                                  bool needs_renderer) {
  auto waiter = std::make_shared<Waiter>();
  waiter->deliver = std::move(deliver);
  std::lock_guard lock(mu_);
  if (draining_ || stopping_) return make_error("server.draining", "the daemon is shutting down");
  if (needs_renderer && ready_workers_ == 0)
    return make_error("renderer.unavailable", "renderer not available: no render worker could create a renderer");
  if (options_.coalesce && !spec.key.empty()) {
    if (auto it = by_key_.find(spec.key); it != by_key_.end() && !it->second->cancelled) {
      waiter->coalesced = true;
      waiter->job = it->second;
      it->second->waiters.push_back(waiter);
      return waiter;
    }
  }
  if (spec.memory_bytes > options_.memory_budget_bytes)
    return make_error("request.memory", fmt::format("the request needs about {} of memory, more than the daemon's "
                                                    "budget of {} (workers.memory_budget_bytes); ask for less",
                                                    format_bytes(spec.memory_bytes),
                                                    format_bytes(options_.memory_budget_bytes)));
  const int capacity = options_.render_workers + options_.encode_threads + options_.queue_depth;
  if (int(active_.size()) >= capacity)
    return make_error("queue.full",
                      fmt::format("the queue is full ({} requests in progress); retry later", active_.size()));
  if (memory_in_flight_ + spec.memory_bytes > options_.memory_budget_bytes)
    return make_error("queue.memory", fmt::format("the request needs about {} of memory and {} of the {} budget are "
                                                  "taken by requests in progress; retry later",
                                                  format_bytes(spec.memory_bytes), format_bytes(memory_in_flight_),
                                                  format_bytes(options_.memory_budget_bytes)));
  memory_in_flight_ += spec.memory_bytes;
  auto job = std::make_shared<Job>();
  job->spec = std::move(spec);
  job->needs_renderer = needs_renderer;
  job->waiters.push_back(waiter);
  waiter->job = job;
  active_.insert(job);
  if (!job->spec.key.empty() && options_.coalesce) by_key_[job->spec.key] = job;
  if (job->spec.render) {
    render_queue_.push_back(job);
    render_cv_.notify_one();
  } else {
    encode_queue_.push_back(job);
    encode_cv_.notify_one();
  }
  return waiter;
}

bool Scheduler::cancel(const std::shared_ptr<Waiter>& waiter) {
  if (waiter->done.exchange(true)) return false;
  std::shared_ptr<Job> abandoned;
  {
    std::lock_guard lock(mu_);
    auto job = waiter->job.lock();
    if (!job) return true;
    auto& ws = job->waiters;
    ws.erase(std::remove(ws.begin(), ws.end(), waiter), ws.end());
    if (!ws.empty()) return true;
    // Nobody waits any more: stop the job at its next stage boundary, and free its
    // queue slot at once if no worker has taken it yet.
    job->cancelled = true;
    if (auto it = by_key_.find(job->spec.key); it != by_key_.end() && it->second == job) by_key_.erase(it);
    if (!job->started) {
      for (auto* q : {&render_queue_, &encode_queue_}) {
        auto it = std::find(q->begin(), q->end(), job);
        if (it != q->end()) {
          q->erase(it);
          active_.erase(job);
          release_memory(*job);
          abandoned = job;
        }
      }
      if (abandoned) idle_cv_.notify_all();
    }
  }
  return true;
}

std::shared_ptr<Job> Scheduler::pop(std::deque<std::shared_ptr<Job>>& q, std::condition_variable& cv) {
  std::unique_lock lock(mu_);
  cv.wait(lock, [&] { return stopping_ || !q.empty(); });
  if (q.empty()) return nullptr;
  auto job = q.front();
  q.pop_front();
  job->started = true;
  ++running_;
  return job;
}

void Scheduler::render_loop(int index) {
  std::unique_ptr<RenderResource> resource;
  {
    auto r = guarded([&] { return factory_ ? factory_(index) : Result<std::unique_ptr<RenderResource>>(nullptr); });
    std::lock_guard lock(mu_);
    if (r && r->ok() && r->value()) {
      resource = std::move(r->value());
      worker_info_[std::size_t(index)] = resource->info();
      ++ready_workers_;
    } else {
      const std::string why = !r ? "renderer creation threw" : (r->ok() ? "no renderer in this build" : r->error().message);
      worker_info_[std::size_t(index)] = {{"error", why}};
      spdlog::warn("render worker {}: renderer not available: {}", index, why);
    }
    ++started_workers_;
    ready_cv_.notify_all();
  }
  while (auto job = pop(render_queue_, render_cv_)) {
    const JobControl control(job->cancelled, job->spec.deadline);
    if (control.cancelled()) {
      finish_job(job, cancelled_reply());
      continue;
    }
    if (control.expired()) {
      finish_job(job, error_reply("request.timeout", "the request timed out while queued"));
      continue;
    }
    auto r = guarded([&] { return job->spec.render(resource.get(), control); });
    if (resource && job->spec.memory_bytes >= options_.trim_after_bytes) resource->release_large_buffers(job->spec.memory_bytes);
    if (!r) {
      finish_job(job, error_reply("internal", "internal error while rendering"));
    } else if (!r->ok()) {
      finish_job(job, std::make_shared<const Reply>(Reply::error(r->error())));
    } else {
      std::unique_lock lock(mu_);
      if (stopping_) {  // the encode pool may be gone already
        lock.unlock();
        finish_job(job, cancelled_reply());
        continue;
      }
      --running_;
      job->started = false;  // waiting again, now for the encode pool
      encode_queue_.push_back(job);
      encode_cv_.notify_one();
    }
  }
  resource.reset();  // the GL context dies on the thread that made it
}

void Scheduler::encode_loop() {
  while (auto job = pop(encode_queue_, encode_cv_)) {
    const JobControl control(job->cancelled, job->spec.deadline);
    if (control.cancelled()) {
      finish_job(job, cancelled_reply());
      continue;
    }
    if (control.expired()) {
      finish_job(job, error_reply("request.timeout", "the request exceeded its time limit"));
      continue;
    }
    auto r = guarded([&] { return job->spec.finish(control); });
    finish_job(job, r ? std::make_shared<const Reply>(std::move(*r))
                      : error_reply("internal", "internal error while encoding"));
  }
}

// Hands the allocator's free memory back once no job has run for trim_idle after a large
// one. Trimming after every large job instead made each job of a burst fault its buffers
// in afresh (docs/performance-daemon.md, "Memory").
void Scheduler::trim_loop() {
  std::unique_lock lock(mu_);
  while (!stopping_) {
    if (!trim_due_) {
      trim_cv_.wait(lock, [&] { return stopping_ || trim_due_.has_value(); });
      continue;
    }
    const auto at = *trim_due_ + options_.trim_idle;
    if (Clock::now() < at) {
      trim_cv_.wait_until(lock, at);
      continue;  // a later job may have moved it, or the daemon is stopping
    }
    if (running_ > 0 || !render_queue_.empty() || !encode_queue_.empty()) {  // still busy: wait for a pause
      trim_due_ = Clock::now();
      continue;
    }
    trim_due_.reset();
    ++trims_;
    lock.unlock();
    ::malloc_trim(0);
    lock.lock();
  }
}

void Scheduler::release_memory(Job& job) {
  if (job.memory_released) return;
  job.memory_released = true;
  memory_in_flight_ -= std::min(memory_in_flight_, job.spec.memory_bytes);
}

void Scheduler::finish_job(const std::shared_ptr<Job>& job, std::shared_ptr<const Reply> reply) {
  std::vector<std::shared_ptr<Waiter>> waiters;
  {
    std::lock_guard lock(mu_);
    if (auto it = by_key_.find(job->spec.key); it != by_key_.end() && it->second == job) by_key_.erase(it);
    waiters.swap(job->waiters);
    --running_;
    active_.erase(job);
    release_memory(*job);
    if (job->spec.memory_bytes >= options_.trim_after_bytes) {  // handed back once idle (trim_loop)
      trim_due_ = Clock::now();
      trim_cv_.notify_all();
    }
    idle_cv_.notify_all();
  }
  for (auto& w : waiters)
    if (!w->done.exchange(true)) w->deliver(reply, w->coalesced);
  // The job's buffers are freed by now, except the reply, which the waiters share until it
  // is sent. glibc keeps freed heap memory for reuse (in every thread's arena); it is handed
  // back once the daemon is idle (trim_loop), after the reply too, which keeps a burst from
  // staying resident.
}

void Scheduler::drain_and_stop(std::chrono::duration<double> timeout) {
  std::deque<std::shared_ptr<Job>> left;
  {
    std::unique_lock lock(mu_);
    if (stopping_ && threads_.empty()) return;
    draining_ = true;
    idle_cv_.wait_for(lock, timeout, [&] { return active_.empty(); });
    stopping_ = true;
    // What is still running stops at its next stage boundary; what waits never starts.
    for (const auto& job : active_) job->cancelled = true;
    for (auto* q : {&render_queue_, &encode_queue_}) {
      for (auto& j : *q) {
        left.push_back(j);
        active_.erase(j);
        release_memory(*j);
      }
      q->clear();
    }
    render_cv_.notify_all();
    encode_cv_.notify_all();
    trim_cv_.notify_all();
  }
  for (auto& job : left) {
    std::vector<std::shared_ptr<Waiter>> waiters;
    {
      std::lock_guard lock(mu_);
      waiters.swap(job->waiters);
    }
    auto reply = cancelled_reply();
    for (auto& w : waiters)
      if (!w->done.exchange(true)) w->deliver(reply, w->coalesced);
  }
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

std::shared_ptr<const Reply> Scheduler::cancelled_reply() const {
  if (draining_) return error_reply("server.draining", "the daemon shut down before the request finished");
  return error_reply("request.cancelled", "the client went away");
}

void Scheduler::set_queue_depth(int depth) {
  std::lock_guard lock(mu_);
  options_.queue_depth = depth;
}

void Scheduler::set_memory_budget(std::uint64_t bytes) {
  std::lock_guard lock(mu_);
  options_.memory_budget_bytes = bytes;
}

SchedulerStats Scheduler::stats() const {
  std::lock_guard lock(mu_);
  SchedulerStats s;
  s.admitted = int(active_.size());
  s.queued = int(render_queue_.size() + encode_queue_.size());
  s.running = running_;
  s.render_workers = options_.render_workers;
  s.render_workers_ready = ready_workers_;
  s.encode_threads = options_.encode_threads;
  s.capacity = options_.render_workers + options_.encode_threads + options_.queue_depth;
  s.memory_in_flight_bytes = memory_in_flight_;
  s.memory_budget_bytes = options_.memory_budget_bytes;
  s.trims = trims_;
  for (const auto& w : worker_info_) s.workers.push_back(w);
  return s;
}

bool Scheduler::renderer_available() const {
  std::lock_guard lock(mu_);
  return ready_workers_ > 0;
}

}  // namespace hdrd::daemon

#include "encode/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include <time.h>

namespace hdrd {
namespace {

// One parallel_run call: its tasks are taken by index; `done` and `users` (workers inside
// it) are guarded by the pool's mutex, and the caller returns only when both say nobody
// will touch the batch again (it lives on the caller's stack).
struct Batch {
  const std::function<void(int)>* task = nullptr;
  CpuMeter* meter = nullptr;  // the caller's: workers add their task time to it
  int count = 0;
  std::atomic<int> next{0};
  int done = 0;
  int users = 0;
};

thread_local bool t_in_pool_task = false;
thread_local CpuMeter* t_meter = nullptr;

std::int64_t thread_cpu_ns() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return std::int64_t(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

class Pool {
 public:
  Pool() {
    for (int i = 1; i < hardware_threads(); ++i) workers_.emplace_back([this] { loop(); });
  }
  ~Pool() {
    {
      std::lock_guard lock(m_);
      stop_ = true;
    }
    work_cv_.notify_all();
    for (auto& w : workers_) w.join();
  }

  void run(int tasks, const std::function<void(int)>& task) {
    if (tasks <= 1 || workers_.empty() || t_in_pool_task) {
      for (int i = 0; i < tasks; ++i) task(i);
      return;
    }
    Batch b;
    b.task = &task;
    b.meter = t_meter;
    b.count = tasks;
    {
      std::lock_guard lock(m_);
      queue_.push_back(&b);
    }
    work_cv_.notify_all();
    drain(b, true);
    std::unique_lock lock(m_);
    done_cv_.wait(lock, [&] { return b.done == b.count && b.users == 0; });
  }

 private:
  void loop() {
    for (;;) {
      Batch* b = nullptr;
      {
        std::unique_lock lock(m_);
        work_cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping
        b = queue_.front();
        ++b->users;
      }
      drain(*b, false);
      std::lock_guard lock(m_);
      if (--b->users == 0) done_cv_.notify_all();
    }
  }

  // Runs the batch's tasks until none is left to take; then the batch leaves the queue.
  // A worker (not the caller, whose own clock its meter reads) adds its task time to the
  // caller's meter.
  void drain(Batch& b, bool caller) {
    const bool was_in_task = t_in_pool_task;
    t_in_pool_task = true;
    for (int i = b.next.fetch_add(1); i < b.count; i = b.next.fetch_add(1)) {
      const std::int64_t t0 = !caller && b.meter ? thread_cpu_ns() : 0;
      (*b.task)(i);
      if (!caller && b.meter) b.meter->add_worker_ns(thread_cpu_ns() - t0);
      std::lock_guard lock(m_);
      if (++b.done == b.count) done_cv_.notify_all();
    }
    t_in_pool_task = was_in_task;
    std::lock_guard lock(m_);
    const auto it = std::find(queue_.begin(), queue_.end(), &b);
    if (it != queue_.end()) queue_.erase(it);
  }

  std::mutex m_;
  std::condition_variable work_cv_, done_cv_;
  std::deque<Batch*> queue_;
  std::vector<std::thread> workers_;
  bool stop_ = false;
};

Pool& pool() {
  static Pool p;
  return p;
}

}  // namespace

int hardware_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

CpuMeter::CpuMeter() : previous_(t_meter), start_ns_(thread_cpu_ns()) { t_meter = this; }
CpuMeter::~CpuMeter() { t_meter = previous_; }
double CpuMeter::ms() const { return double(thread_cpu_ns() - start_ns_ + workers_ns_.load()) / 1e6; }
CpuMeter* CpuMeter::current() { return t_meter; }
void CpuMeter::add_worker_ns(std::int64_t ns) {
  for (CpuMeter* m = this; m; m = m->previous_) m->workers_ns_ += ns;
}

void parallel_run(int tasks, const std::function<void(int)>& task) { pool().run(tasks, task); }

void parallel_for(std::size_t count, int threads, std::size_t min_chunk,
                  const std::function<void(std::size_t, std::size_t)>& fn) {
  std::size_t parts = threads > 0 ? static_cast<std::size_t>(threads) : static_cast<std::size_t>(hardware_threads());
  parts = std::max<std::size_t>(1, std::min(parts, count / std::max<std::size_t>(min_chunk, 1)));
  if (parts <= 1) {
    if (count > 0) fn(0, count);
    return;
  }
  const std::size_t step = ((count + parts - 1) / parts + 63) / 64 * 64;
  const int chunks = static_cast<int>((count + step - 1) / step);
  parallel_run(chunks, [&](int i) {
    const std::size_t begin = static_cast<std::size_t>(i) * step;
    fn(begin, std::min(count, begin + step));
  });
}

}  // namespace hdrd

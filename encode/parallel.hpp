// One process-wide pool of worker threads for the encoder's data-parallel loops (the frame
// kernel's row bands, LUT application, half conversion, the gain map), so that per-frame
// work never creates threads: a 4K frame at 2 threads takes ~12 ms, in which spawning and
// joining threads per frame was measurable. The pool has hardware_threads() - 1 workers;
// the calling thread is always one of the runners.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>

namespace hdrd {

// std::thread::hardware_concurrency(), at least 1.
int hardware_threads();

// Calls task(i) once for each i in [0, tasks), on the pool's workers and the calling
// thread, and returns when every call has returned. Calls from several threads share the
// workers (each call's own thread always works on it, so none waits for another's); a call
// made from inside a task runs its tasks on that thread. Tasks must not throw.
void parallel_run(int tasks, const std::function<void(int)>& task);

// fn(begin, end) over [0, count) in at most `threads` parts (0 = hardware_threads()) of at
// least min_chunk items; part edges on 64-item boundaries keep each part's writes on its
// own cache lines.
void parallel_for(std::size_t count, int threads, std::size_t min_chunk,
                  const std::function<void(std::size_t, std::size_t)>& fn);

// The CPU time of one piece of work that may fan out over the pool: the calling thread's
// own time while the meter lives, plus what pool workers spend on the tasks of the
// parallel_run calls made (directly or nested) from that thread meanwhile. Unlike the
// process's CPU clock it leaves out the process's other threads (a sequence's writer, a
// video encoder, another request's job). Meters nest: an outer one counts the inner ones'.
class CpuMeter {
 public:
  CpuMeter();
  ~CpuMeter();
  CpuMeter(const CpuMeter&) = delete;
  CpuMeter& operator=(const CpuMeter&) = delete;

  double ms() const;                       // so far
  void add_worker_ns(std::int64_t ns);     // to this meter and the ones it is nested in
  static CpuMeter* current();              // this thread's innermost meter, or null

 private:
  CpuMeter* previous_;
  std::int64_t start_ns_;
  std::atomic<std::int64_t> workers_ns_{0};
};

}  // namespace hdrd

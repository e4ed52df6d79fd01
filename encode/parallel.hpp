// One process-wide pool of worker threads for the encoder's data-parallel loops (the frame
// kernel's row bands, LUT application, half conversion, the gain map), so that per-frame
// work never creates threads: a 4K frame at 2 threads takes ~12 ms, in which spawning and
// joining threads per frame was measurable. The pool has hardware_threads() - 1 workers;
// the calling thread is always one of the runners.
#pragma once

#include <cstddef>
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

}  // namespace hdrd

// The shared worker pool: every task runs exactly once, calls from several threads at once
// and calls from inside a task complete (no deadlock), parallel_for covers its range.
#include <gtest/gtest.h>

#include <time.h>

#include <atomic>
#include <thread>
#include <vector>

#include "encode/parallel.hpp"

namespace hdrd {
namespace {

TEST(Parallel, EveryTaskRunsOnce) {
  for (int tasks : {0, 1, 2, 3, 17, 1000}) {
    std::vector<std::atomic<int>> runs(static_cast<std::size_t>(tasks));
    parallel_run(tasks, [&](int i) { runs[static_cast<std::size_t>(i)].fetch_add(1); });
    for (int i = 0; i < tasks; ++i) EXPECT_EQ(runs[static_cast<std::size_t>(i)].load(), 1) << tasks << " tasks, #" << i;
  }
}

TEST(Parallel, ConcurrentAndNestedCallsComplete) {
  std::atomic<long> sum{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 8; ++c)
    callers.emplace_back([&] {
      for (int round = 0; round < 50; ++round)
        parallel_run(4, [&](int) { parallel_run(3, [&](int k) { sum.fetch_add(k + 1); }); });
    });
  for (auto& t : callers) t.join();
  EXPECT_EQ(sum.load(), 8L * 50 * 4 * (1 + 2 + 3));
}

TEST(Parallel, ForCoversTheRangeInAlignedParts) {
  for (std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{63}, std::size_t{64 * 5 + 3}, std::size_t{100000}}) {
    std::vector<std::atomic<int>> hit(count);
    std::atomic<int> misaligned{0};
    parallel_for(count, 4, 8, [&](std::size_t b, std::size_t e) {
      if (b % 64 != 0) misaligned.fetch_add(1);
      for (std::size_t i = b; i < e; ++i) hit[i].fetch_add(1);
    });
    for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(hit[i].load(), 1) << count << " items, #" << i;
    EXPECT_EQ(misaligned.load(), 0);
  }
}

}  // namespace
}  // namespace hdrd

namespace hdrd {
namespace {

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}
// Burns `ms` of this thread's CPU (not wall time: a loaded machine does not change it).
void spin(double ms) {
  volatile double x = 0;
  for (const double end = thread_cpu_ms() + ms; thread_cpu_ms() < end;)
    for (int i = 0; i < 1000; ++i) x = x + 1;
}

// The meter counts its thread and the pool's tasks for it (nested calls included, outer
// meters too), and not another thread of the process that works meanwhile.
TEST(CpuMeter, CountsThePoolsTasksForItAndNothingElse) {
  std::atomic<bool> stop{false};
  std::thread other([&] {
    while (!stop) spin(1);
  });
  const CpuMeter outer;
  double inner_ms = 0;
  {
    const CpuMeter meter;
    EXPECT_EQ(CpuMeter::current(), &meter);
    parallel_run(4, [](int) { spin(15); });
    inner_ms = meter.ms();
  }
  EXPECT_EQ(CpuMeter::current(), &outer);
  stop = true;
  other.join();
  EXPECT_GE(inner_ms, 60.0);
  EXPECT_LT(inner_ms, 60.0 + 15.0) << "the other thread's CPU must not count";
  EXPECT_GE(outer.ms(), inner_ms);
  EXPECT_LT(outer.ms(), inner_ms + 15.0);
}

}  // namespace
}  // namespace hdrd

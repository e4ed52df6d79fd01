// The scheduler without HTTP: admission limits, coalescing, cancellation of queued and
// running jobs, drain, and a render worker without a renderer. Jobs block on latches the
// test opens, so every ordering here is forced, not timed.
#include <gtest/gtest.h>

#include <condition_variable>
#include <future>
#include <cmath>
#include <limits>
#include <mutex>
#include <thread>

#include "daemon/jobs/scheduler.hpp"

namespace hdrd::daemon {
namespace {

class FakeResource final : public RenderResource {
 public:
  nlohmann::json info() const override { return {{"backend", "fake"}}; }
};

RenderResourceFactory fake_factory() {
  return [](int) -> Result<std::unique_ptr<RenderResource>> { return std::unique_ptr<RenderResource>(new FakeResource); };
}

// A gate a job waits at until the test opens it.
class Gate {
 public:
  void open() {
    std::lock_guard l(mu_);
    open_ = true;
    cv_.notify_all();
  }
  void wait() {
    std::unique_lock l(mu_);
    cv_.wait(l, [&] { return open_; });
  }
  void arrived() {
    std::lock_guard l(mu_);
    ++arrived_;
    cv_.notify_all();
  }
  void wait_arrivals(int n) {
    std::unique_lock l(mu_);
    cv_.wait(l, [&] { return arrived_ >= n; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool open_ = false;
  int arrived_ = 0;
};

struct Delivery {
  std::promise<std::pair<std::shared_ptr<const Reply>, bool>> promise;
  std::future<std::pair<std::shared_ptr<const Reply>, bool>> future = promise.get_future();
  std::function<void(std::shared_ptr<const Reply>, bool)> fn() {
    return [this](std::shared_ptr<const Reply> r, bool coalesced) { promise.set_value({r, coalesced}); };
  }
};

SchedulerOptions options(int render_workers, int encode_threads, int queue_depth, bool coalesce) {
  SchedulerOptions o;
  o.render_workers = render_workers;
  o.encode_threads = encode_threads;
  o.queue_depth = queue_depth;
  o.coalesce = coalesce;
  return o;
}

JobSpec gated_job(Gate& gate, std::string key, std::string body, std::atomic<int>* runs = nullptr) {
  JobSpec s;
  s.key = std::move(key);
  s.deadline = Clock::now() + std::chrono::hours(1);
  s.render = [&gate, runs](RenderResource* r, const JobControl&) -> Result<void> {
    if (!r) return make_error("renderer.unavailable", "none");
    if (runs) ++*runs;
    gate.arrived();
    gate.wait();
    return {};
  };
  s.finish = [body](const JobControl&) { return Reply::json(200, body); };
  return s;
}

TEST(Scheduler, AdmitsUpToCapacityThenRefuses) {
  Scheduler s(options(/*render_workers=*/1, /*encode_threads=*/1, /*queue_depth=*/1, /*coalesce=*/false), fake_factory());
  s.start();
  Gate gate;
  std::vector<std::unique_ptr<Delivery>> d;
  for (int i = 0; i < 3; ++i) {
    d.push_back(std::make_unique<Delivery>());
    ASSERT_TRUE(s.submit(gated_job(gate, "", std::to_string(i)), d.back()->fn(), true).ok()) << i;
  }
  Delivery extra;
  auto refused = s.submit(gated_job(gate, "", "x"), extra.fn(), true);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "queue.full");
  EXPECT_EQ(s.stats().capacity, 3);
  gate.open();
  for (int i = 0; i < 3; ++i) EXPECT_EQ(*d[std::size_t(i)]->future.get().first->body, std::to_string(i));
  s.drain_and_stop(std::chrono::seconds(5));
}

// The allocator's free memory goes back once the daemon is idle after a large job, not
// between the jobs of a burst (they reuse it), and never for small jobs alone.
TEST(Scheduler, FreeMemoryIsHandedBackOnceIdleAfterALargeJob) {
  SchedulerOptions o = options(1, 1, 4, false);
  o.trim_idle = std::chrono::milliseconds(100);
  Scheduler s(o, fake_factory());
  s.start();
  auto job = [](std::uint64_t bytes, std::chrono::milliseconds takes) {
    JobSpec j;
    j.deadline = Clock::now() + std::chrono::hours(1);
    j.memory_bytes = bytes;
    j.finish = [takes](const JobControl&) {
      std::this_thread::sleep_for(takes);
      return Reply::json(200, "{}");
    };
    return j;
  };
  auto run = [&](std::uint64_t bytes, std::chrono::milliseconds takes) {
    Delivery d;
    ASSERT_TRUE(s.submit(job(bytes, takes), d.fn(), false).ok());
    d.future.get();
  };
  const std::uint64_t large = o.trim_after_bytes, small = o.trim_after_bytes - 1;
  run(small, std::chrono::milliseconds(0));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(s.stats().trims, 0u) << "a small job gives nothing back";
  for (int i = 0; i < 5; ++i) run(large, std::chrono::milliseconds(20));  // a burst
  EXPECT_EQ(s.stats().trims, 0u) << "no trim between the jobs of a burst";
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  EXPECT_EQ(s.stats().trims, 1u) << "one trim once idle";
  // Busy with a long job past trim_idle: the trim waits until it is over.
  run(large, std::chrono::milliseconds(0));
  Delivery d;
  ASSERT_TRUE(s.submit(job(small, std::chrono::milliseconds(400)), d.fn(), false).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  EXPECT_EQ(s.stats().trims, 1u) << "no trim while a job runs";
  d.future.get();
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  EXPECT_EQ(s.stats().trims, 2u);
  s.drain_and_stop(std::chrono::seconds(5));
}

TEST(Scheduler, IdenticalKeysShareOneJob) {
  Scheduler s(options(1, 1, 4, true), fake_factory());
  s.start();
  Gate gate;
  std::atomic<int> runs{0};
  Delivery a, b, c;
  ASSERT_TRUE(s.submit(gated_job(gate, "same", "frame", &runs), a.fn(), true).ok());
  gate.wait_arrivals(1);  // the first is running: the others join it
  ASSERT_TRUE(s.submit(gated_job(gate, "same", "frame", &runs), b.fn(), true).ok());
  ASSERT_TRUE(s.submit(gated_job(gate, "same", "frame", &runs), c.fn(), true).ok());
  EXPECT_EQ(s.stats().admitted, 1);
  gate.open();
  auto ra = a.future.get(), rb = b.future.get(), rc = c.future.get();
  EXPECT_EQ(runs.load(), 1);
  EXPECT_FALSE(ra.second);
  EXPECT_TRUE(rb.second);
  EXPECT_TRUE(rc.second);
  EXPECT_EQ(ra.first, rb.first) << "the very same reply object";
  s.drain_and_stop(std::chrono::seconds(5));
}

TEST(Scheduler, CancellingAQueuedJobFreesItsSlotAndItNeverRuns) {
  Scheduler s(options(1, 1, 0, false), fake_factory());  // capacity 2
  s.start();
  Gate gate;
  std::atomic<int> runs{0};
  Delivery a, b, c;
  ASSERT_TRUE(s.submit(gated_job(gate, "", "a", &runs), a.fn(), true).ok());
  gate.wait_arrivals(1);  // "a" holds the only render worker
  auto wb = s.submit(gated_job(gate, "", "b", &runs), b.fn(), true);
  ASSERT_TRUE(wb.ok());
  EXPECT_EQ(s.submit(gated_job(gate, "", "c", &runs), c.fn(), true).error().code, "queue.full");
  EXPECT_TRUE(s.cancel(*wb));  // "b"'s client left while it waited
  ASSERT_TRUE(s.submit(gated_job(gate, "", "c", &runs), c.fn(), true).ok()) << "its slot is free at once";
  gate.open();
  EXPECT_EQ(*a.future.get().first->body, "a");
  EXPECT_EQ(*c.future.get().first->body, "c");
  EXPECT_EQ(runs.load(), 2) << "the cancelled job never ran";
  EXPECT_EQ(b.future.wait_for(std::chrono::seconds(0)), std::future_status::timeout);
  s.drain_and_stop(std::chrono::seconds(5));
}

TEST(Scheduler, CancelDetachesOneWaiterAndStopsAnAbandonedJob) {
  Scheduler s(options(1, 1, 4, true), fake_factory());
  s.start();
  Gate gate;
  std::atomic<int> runs{0};
  Delivery first, joined, queued;
  auto w1 = s.submit(gated_job(gate, "k", "frame", &runs), first.fn(), true);
  ASSERT_TRUE(w1.ok());
  gate.wait_arrivals(1);
  auto w2 = s.submit(gated_job(gate, "k", "frame", &runs), joined.fn(), true);
  auto w3 = s.submit(gated_job(gate, "other", "other", &runs), queued.fn(), true);
  ASSERT_TRUE(w2.ok() && w3.ok());
  EXPECT_TRUE(s.cancel(*w1)) << "the first client left; the joined one still waits";
  EXPECT_FALSE(s.cancel(*w1)) << "only once";
  EXPECT_TRUE(s.cancel(*w3)) << "queued and abandoned: dropped";
  EXPECT_EQ(s.stats().admitted, 1);
  gate.open();
  auto r = joined.future.get();
  EXPECT_EQ(r.first->status, 200);
  EXPECT_EQ(runs.load(), 1) << "the abandoned queued job never ran";
  EXPECT_EQ(first.future.wait_for(std::chrono::seconds(0)), std::future_status::timeout) << "a cancelled waiter gets nothing";
  s.drain_and_stop(std::chrono::seconds(5));
}

TEST(Scheduler, DrainFinishesRunningJobsAndAnswersQueuedOnes) {
  Scheduler s(options(1, 1, 4, false), fake_factory());
  s.start();
  Gate gate;
  Delivery running, queued;
  ASSERT_TRUE(s.submit(gated_job(gate, "", "done", nullptr), running.fn(), true).ok());
  gate.wait_arrivals(1);
  ASSERT_TRUE(s.submit(gated_job(gate, "", "late", nullptr), queued.fn(), true).ok());
  std::thread opener([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    gate.open();
  });
  s.drain_and_stop(std::chrono::seconds(30));  // waits for both
  opener.join();
  EXPECT_EQ(*running.future.get().first->body, "done");
  EXPECT_EQ(*queued.future.get().first->body, "late");
  Delivery after;
  auto refused = s.submit(gated_job(gate, "", "x"), after.fn(), true);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "server.draining");
}

TEST(Scheduler, DrainTimeoutCancelsWhatIsLeft) {
  Scheduler s(options(1, 1, 4, false), fake_factory());
  s.start();
  Gate gate;
  Delivery running, queued;
  ASSERT_TRUE(s.submit(gated_job(gate, "", "a", nullptr), running.fn(), true).ok());
  gate.wait_arrivals(1);
  ASSERT_TRUE(s.submit(gated_job(gate, "", "b", nullptr), queued.fn(), true).ok());
  std::thread stopper([&] { s.drain_and_stop(std::chrono::milliseconds(0)); });
  auto q = queued.future.get();  // answered by the drain while "a" still runs
  EXPECT_EQ(q.first->status, 503u);
  EXPECT_EQ(q.first->error_code, "server.draining");
  gate.open();
  stopper.join();
  auto r = running.future.get();
  EXPECT_EQ(r.first->error_code, "server.draining") << "cancelled at its stage boundary";
}

TEST(Scheduler, NoRendererMeansRenderJobsAreRefused) {
  Scheduler s(options(1, 1, 4, false),
              [](int) -> Result<std::unique_ptr<RenderResource>> { return make_error("gl.egl", "no EGL here"); });
  s.start();
  EXPECT_FALSE(s.renderer_available());
  EXPECT_EQ(s.stats().workers[0]["error"], "no EGL here");
  Gate gate;
  Delivery d;
  auto r = s.submit(gated_job(gate, "", "x"), d.fn(), true);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "renderer.unavailable");
  // Jobs without a render stage still run.
  JobSpec plain;
  plain.deadline = Clock::now() + std::chrono::hours(1);
  plain.finish = [](const JobControl&) { return Reply::json(200, "ok"); };
  Delivery e;
  ASSERT_TRUE(s.submit(std::move(plain), e.fn(), false).ok());
  EXPECT_EQ(*e.future.get().first->body, "ok");
  s.drain_and_stop(std::chrono::seconds(5));
}

TEST(Scheduler, ExpiredJobsAreAnsweredWithTimeout) {
  Scheduler s(options(1, 1, 4, false), fake_factory());
  s.start();
  JobSpec j;
  j.deadline = Clock::now() - std::chrono::seconds(1);
  j.render = [](RenderResource*, const JobControl&) -> Result<void> { return {}; };
  j.finish = [](const JobControl&) { return Reply::json(200, "late"); };
  Delivery d;
  ASSERT_TRUE(s.submit(std::move(j), d.fn(), true).ok());
  auto r = d.future.get();
  EXPECT_EQ(r.first->status, 504u);
  EXPECT_EQ(r.first->error_code, "request.timeout");
  s.drain_and_stop(std::chrono::seconds(5));
}

// Admission weighs memory: a job alone beyond the budget is the client's fault (400
// request.memory); one that does not fit beside the admitted ones is 503 queue.memory, and
// fits again once they finish. Coalesced waiters add nothing.
TEST(Scheduler, MemoryBudgetBoundsWhatIsAdmitted) {
  auto o = options(1, 2, 8, true);
  o.memory_budget_bytes = 100 << 20;
  Scheduler s(o, fake_factory());
  s.start();
  Gate gate;
  auto job = [&](std::string key, std::uint64_t mib) {
    JobSpec j = gated_job(gate, std::move(key), "m");
    j.memory_bytes = mib << 20;
    return j;
  };
  Delivery too_big;
  auto r = s.submit(job("", 101), too_big.fn(), true);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.memory");
  EXPECT_EQ(http_status(r.error()), 400u);
  EXPECT_NE(r.error().message.find("101 MiB"), std::string::npos) << r.error().message;

  Delivery a, shared, b;
  ASSERT_TRUE(s.submit(job("a", 60), a.fn(), true).ok());
  ASSERT_TRUE(s.submit(job("a", 60), shared.fn(), true).ok()) << "an identical request joins the admitted job";
  EXPECT_EQ(s.stats().memory_in_flight_bytes, 60u << 20);
  auto refused = s.submit(job("b", 50), b.fn(), true);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, "queue.memory");
  EXPECT_EQ(http_status(refused.error()), 503u);
  gate.open();
  EXPECT_EQ(a.future.get().first->status, 200u);
  EXPECT_TRUE(shared.future.get().second);
  for (int i = 0; i < 200 && s.stats().memory_in_flight_bytes != 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(s.stats().memory_in_flight_bytes, 0u);
  Delivery later;
  EXPECT_TRUE(s.submit(job("b", 50), later.fn(), true).ok());
  EXPECT_EQ(later.future.get().first->status, 200u);
  s.drain_and_stop(std::chrono::seconds(5));
}

// A cancelled queued job gives its memory back at once.
TEST(Scheduler, CancelledQueuedJobReleasesItsMemory) {
  auto o = options(1, 1, 4, false);
  o.memory_budget_bytes = 100 << 20;
  Scheduler s(o, fake_factory());
  s.start();
  Gate gate;
  Delivery running, queued;
  JobSpec first = gated_job(gate, "", "1");
  first.memory_bytes = 10 << 20;
  ASSERT_TRUE(s.submit(std::move(first), running.fn(), true).ok());
  gate.wait_arrivals(1);
  JobSpec second = gated_job(gate, "", "2");
  second.memory_bytes = 80 << 20;
  auto w = s.submit(std::move(second), queued.fn(), true);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(s.stats().memory_in_flight_bytes, 90u << 20);
  EXPECT_TRUE(s.cancel(*w));
  EXPECT_EQ(s.stats().memory_in_flight_bytes, 10u << 20);
  gate.open();
  running.future.get();
  s.drain_and_stop(std::chrono::seconds(5));
}

// A deadline far beyond any request saturates instead of wrapping into the past (issue 14:
// max_request_seconds = 1e300 made every request time out while queued).
TEST(Scheduler, DeadlinesSaturate) {
  const auto now = Clock::now();
  EXPECT_GT(deadline_after(now, 1e300), now + std::chrono::hours(24 * 300));
  EXPECT_GT(deadline_after(now, std::numeric_limits<double>::infinity()), now);
  EXPECT_EQ(deadline_after(now, std::nan("")), now);
  EXPECT_EQ(deadline_after(now, -5), now);
  EXPECT_EQ(deadline_after(now, 2.5) - now, std::chrono::milliseconds(2500));
}

}  // namespace
}  // namespace hdrd::daemon

// What the daemon keeps of its sequence jobs and counts for them (issue 28.10): a finished
// job keeps its record, not its request (uploads included), and what it keeps is counted;
// a long sequence's per-frame metadata is in its admission estimate.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <nlohmann/json.hpp>

#include "daemon/jobs/jobs.hpp"
#include "daemon/jobs/memory.hpp"
#include "job/request.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::daemon {
namespace {

using nlohmann::json;

Result<job::FrameRequest> sequence_request(job::Source source, const json& body) {
  job::ParseContext ctx;
  ctx.source = source;
  ctx.sequence = true;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<std::filesystem::path> {
    return std::filesystem::path(p);
  };
  return job::parse_request_json(body, ctx);
}

// Each finished job held its request: a 7.8 MB ui.png_base64 added 7.5 MB per job kept in
// the history. Ten such jobs, finished (they fail at once: no frames), keep a few KiB each.
TEST(JobMemory, AFinishedJobKeepsItsRecordNotItsRequest) {
  testing::TempDir dir;
  JobRegistryOptions o;
  o.history = 20;
  o.max_queued = 20;
  JobRegistry jobs(o);
  constexpr int kJobs = 10;
  constexpr std::size_t kUpload = std::size_t(15) << 19;  // 7.5 MiB, as decoded
  std::vector<std::string> ids;
  for (int i = 0; i < kJobs; ++i) {
    auto r = sequence_request(job::Source::encode, {{"images", (dir / "none.%04d.exr").string()}});
    ASSERT_TRUE(r.ok()) << r.error().message;
    SequenceSpec spec;
    spec.request = std::move(*r);
    spec.request.ui_png.assign(kUpload, 0x55);
    spec.name = "m" + std::to_string(i);
    spec.outbase = dir / spec.name;
    spec.memory_bytes = 1 << 20;
    auto info = jobs.submit(std::move(spec));
    ASSERT_TRUE(info.ok()) << info.error().message;
    ids.push_back(info->id);
  }
  for (const auto& id : ids)
    for (int k = 0; k < 500 && !is_final(jobs.get(id)->state); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  for (const auto& id : ids) ASSERT_EQ(jobs.get(id)->state, JobState::failed) << "the job did not end";
  const auto s = jobs.stats();
  EXPECT_EQ(s.finished, kJobs);
  EXPECT_EQ(s.memory_in_flight_bytes, 0u);
  EXPECT_GT(s.memory_kept_bytes, 0u) << "what is kept is counted";
  EXPECT_LT(s.memory_kept_bytes, std::uint64_t(kJobs) * (16u << 10)) << "a kept job holds its record only, not its upload";
}

// A long sequence's metadata (a sidecar entry and a light summary per frame, ~1 MB per 1000
// frames measured) grew outside the admission estimate.
TEST(JobMemory, TheEstimateCountsEveryFramesMetadata) {
  auto r = sequence_request(job::Source::render, {{"scene", "furnace"}, {"frames", 1000}, {"width", 64}, {"height", 32}});
  ASSERT_TRUE(r.ok()) << r.error().message;
  const job::Limits limits;
  auto shorter = estimate_sequence_memory(*r, {}, {}, 2, 100, limits, 1000);
  auto longer = estimate_sequence_memory(*r, {}, {}, 2, 100, limits, 101000);
  ASSERT_TRUE(shorter.ok() && longer.ok());
  EXPECT_GE(*longer - *shorter, 100000u * 1000u) << "at least the measured 1 KB per frame";
}

}  // namespace
}  // namespace hdrd::daemon

// Sharded sequences (job/sequence_plan.hpp): the same sequence in one process and as N shards
// (each its own run over the plan read back from disk), merged, gives identical per-frame
// dumps, identical decisions (no exposure step at shard boundaries), identical sequence
// metadata and HDR10+/DV files, and a video that decodes to the same pictures (lossless:
// the encoder is otherwise free to spend bits differently at shard starts, where each shard's
// fresh encoder begins with a keyframe and sees no frames before it). A retried shard writes
// the same bytes; the merge refuses missing, foreign or edited shards and plans.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "encode/video/writer.hpp"
#include "job/sequence.hpp"
#include "job/sequence_plan.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::job {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kW = 64, kH = 16;  // x265 takes frames 64 pixels wide or more
const bool kQuiet = (video::quiet_codec_logs(), true);

// A shot that brightens by a stop every 3 frames, then a cut to a dim one: adaptation is
// still moving at every shard boundary, and one boundary falls inside a scene.
void write_shots(const fs::path& dir, int n) {
  for (int i = 0; i < n; ++i) {
    const double gain = i < 7 ? std::exp2(i / 3.0) : 0.05;
    Image img(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        for (int c = 0; c < 3; ++c)
          img.rgba[(static_cast<std::size_t>(y) * kW + x) * 4 + c] =
              static_cast<float>(gain * 0.03 * (x + 1) * (1 + 0.2 * c) * (1 + 0.1 * ((x + i) % 5)));
    ASSERT_TRUE(io::write_exr(dir / fmt::format("s.{}.exr", i), img, {}).ok());
  }
}

ParseContext context() {
  ParseContext ctx;
  ctx.source = Source::encode;
  ctx.reach = Reach::cli;
  ctx.sequence = true;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<fs::path> { return fs::path(p); };
  return ctx;
}

std::string bytes_of(const fs::path& p) { return testing::read_file(p); }

struct Fixture {
  testing::TempDir d;
  json request;
  static constexpr int kFrames = 10;
  Fixture() {
    fs::create_directories(d / "in");
    write_shots(d / "in", kFrames);
    request = {{"images", (d / "in" / "s.%d.exr").string()},
               {"exposure", {{"mode", "histogram"}, {"adaptation_time_s", 0.5}}},
               {"tone", {{"curve", "bt2390"}}},
               {"formats", {"raw"}},
               {"video", {{"codec", "hevc"}, {"lossless", true}, {"preset", "ultrafast"}}}};
  }
  Result<SequenceResult> one_process(const fs::path& outbase) {
    auto r = parse_request_json(request, context());
    if (!r) return r.error();
    return run_sequence(*r, outbase, {});
  }
  Result<SequencePlan> plan(int shards) {
    auto p = make_sequence_plan(request, Source::encode, shards, d / "plan.json", {});
    if (!p) return p.error();
    if (auto ok = write_sequence_plan(*p); !ok) return ok.error();
    return read_sequence_plan(d / "plan.json");  // as a shard on another machine reads it
  }
};

TEST(SequencePlan, ShardsMergeIntoTheOneProcessResult) {
  Fixture f;
  auto one = f.one_process(f.d / "one");
  ASSERT_TRUE(one.ok()) << one.error().message;
  auto plan = f.plan(3);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->frames, Fixture::kFrames);
  ASSERT_EQ(plan->ranges.size(), 3u);
  EXPECT_EQ(plan->ranges[1], (std::pair<int, int>{3, 3}));
  for (int i = 0; i < 3; ++i) {
    auto r = run_sequence_shard(*plan, i, {});
    ASSERT_TRUE(r.ok()) << "shard " << i << ": " << r.error().message;
    EXPECT_TRUE(fs::exists(plan->resolved_work_dir() / fmt::format("shard-{}.done", i)));
  }
  auto merged = merge_sequence_plan(*plan, f.d / "merged");
  ASSERT_TRUE(merged.ok()) << merged.error().message;

  for (int i = 0; i < Fixture::kFrames; ++i)
    EXPECT_EQ(bytes_of(f.d / fmt::format("merged.{:05d}.raw", i)), bytes_of(f.d / fmt::format("one.{:05d}.raw", i)))
        << "frame " << i;
  const json &a = merged->sidecar, &b = one->sidecar;
  EXPECT_EQ(a["frames"], b["frames"]);  // every decision: exposure, scene, peak, light
  EXPECT_EQ(a["scenes"], b["scenes"]);
  EXPECT_EQ(a["content_light_level"], b["content_light_level"]);
  EXPECT_EQ(a["scenes"].size(), 2u) << "the cut to the dim shot";
  EXPECT_EQ(bytes_of(f.d / "merged.hdr10plus.json"), bytes_of(f.d / "one.hdr10plus.json"));
  EXPECT_EQ(bytes_of(f.d / "merged.dovi.json"), bytes_of(f.d / "one.dovi.json"));
  // The per-frame sidecars name their files as the one-process run's do (its own OUTBASE).
  auto frame_json = [&](const char* base, int i) {
    json j = json::parse(bytes_of(f.d / fmt::format("{}.{:05d}.json", base, i)));
    j.erase("files");
    return j;
  };
  EXPECT_EQ(frame_json("merged", 4), frame_json("one", 4));
  EXPECT_EQ(json::parse(bytes_of(f.d / "merged.00004.json"))["files"]["raw"], "merged.00004.raw");
  // No step at the boundaries: the exposure moves as the one-process run's.
  for (int i = 1; i < Fixture::kFrames; ++i)
    EXPECT_EQ(a["frames"][i]["exposure_scale"], b["frames"][i]["exposure_scale"]) << "frame " << i;
  EXPECT_EQ(a["video"]["frames"], Fixture::kFrames);

  // The pictures of both videos (lossless): ffmpeg's decoder, frame by frame.
  if (testing::run_command("ffmpeg -version").exit_code != 0) GTEST_SKIP() << "ffmpeg missing: the videos' pictures not compared";
  auto decode = [&](const char* base) {
    const fs::path yuv = f.d / fmt::format("{}.yuv", base);
    EXPECT_EQ(testing::run_command(fmt::format("ffmpeg -v error -i '{}' -f rawvideo -pix_fmt yuv420p10le '{}'",
                                               (f.d / fmt::format("{}.mp4", base)).string(), yuv.string()))
                  .exit_code,
              0);
    return bytes_of(yuv);
  };
  const std::string pa = decode("merged"), pb = decode("one");
  EXPECT_EQ(pa.size(), static_cast<std::size_t>(Fixture::kFrames * kW * kH * 3));
  EXPECT_TRUE(pa == pb) << "decoded pictures differ";
}

TEST(SequencePlan, RetriedShardWritesTheSameBytes) {
  Fixture f;
  auto plan = f.plan(2);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  const fs::path w = plan->resolved_work_dir();
  ASSERT_TRUE(run_sequence_shard(*plan, 1, {}).ok());
  const std::string seg = bytes_of(w / "shard-1.segment"), stats = bytes_of(w / "shard-1.json"),
                    frame = bytes_of(w / "frames" / "frame.00007.raw");
  ASSERT_TRUE(run_sequence_shard(*plan, 1, {}).ok());
  EXPECT_TRUE(seg == bytes_of(w / "shard-1.segment"));
  EXPECT_EQ(stats, bytes_of(w / "shard-1.json"));
  EXPECT_EQ(frame, bytes_of(w / "frames" / "frame.00007.raw"));
}

TEST(SequencePlan, MergeRefusesMissingForeignAndEditedShards) {
  Fixture f;
  auto plan = f.plan(2);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_TRUE(run_sequence_shard(*plan, 0, {}).ok());
  auto m = merge_sequence_plan(*plan, f.d / "out");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("shard 1 of 2 is missing"), std::string::npos) << m.error().message;
  ASSERT_TRUE(run_sequence_shard(*plan, 1, {}).ok());
  // A shard of another plan: its .done names another fingerprint.
  const fs::path done = plan->resolved_work_dir() / "shard-1.done";
  std::ofstream(done) << "0123456789abcdef\n";
  m = merge_sequence_plan(*plan, f.d / "out");
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("another plan"), std::string::npos) << m.error().message;
  for (const auto& e : fs::directory_iterator(f.d.path())) EXPECT_NE(e.path().stem().string().rfind("out", 0), 0u) << e.path();
  // An edited plan is refused when it is read.
  std::string text = bytes_of(f.d / "plan.json");
  text.replace(text.find("\"exposure_scale\": "), 18, "\"exposure_scale\": 2");
  std::ofstream(f.d / "edited.json") << text;
  auto edited = read_sequence_plan(f.d / "edited.json");
  ASSERT_FALSE(edited.ok());
  EXPECT_NE(edited.error().message.find("fingerprint"), std::string::npos) << edited.error().message;
  // ... its work dir too (issue 28.11: an edited work_dir wrote outside the plan's folder).
  text = bytes_of(f.d / "plan.json");
  const std::string work_dir = "\"work_dir\": " + json(plan->work_dir.string()).dump();
  ASSERT_NE(text.find(work_dir), std::string::npos) << text.substr(0, 400);
  text.replace(text.find(work_dir), work_dir.size(), "\"work_dir\": \"/tmp/elsewhere\"");
  std::ofstream(f.d / "moved.json") << text;
  auto moved = read_sequence_plan(f.d / "moved.json");
  ASSERT_FALSE(moved.ok()) << "a plan whose work_dir was edited is read";
  EXPECT_NE(moved.error().message.find("fingerprint"), std::string::npos) << moved.error().message;
  std::ofstream(f.d / "junk.json") << "{\"format\": \"hdrd-sequence-plan\", \"format_version\": 1, \"shards\": 0}";
  EXPECT_EQ(read_sequence_plan(f.d / "junk.json").error().code, "sequence.plan");
  EXPECT_EQ(run_sequence_shard(*plan, 2, {}).error().code, "request.value");
  EXPECT_EQ(make_sequence_plan(f.request, Source::encode, 11, f.d / "p.json", {}).error().code, "request.value");
}

TEST(SequencePlan, RenderSequenceShards) {
  testing::TempDir d;
  const json request = {{"scene", "furnace"}, {"width", 24}, {"height", 16}, {"samples", 1}, {"frames", 3},
                        {"formats", {"raw"}}};
  ParseContext ctx = context();
  ctx.source = Source::render;
  auto r = parse_request_json(request, ctx);
  ASSERT_TRUE(r.ok());
  auto one = run_sequence(*r, d / "one", {});
  if (!one.ok() && one.error().code.rfind("render", 0) == 0) GTEST_SKIP() << "no GL renderer: " << one.error().message;
  ASSERT_TRUE(one.ok()) << one.error().message;
  auto plan = make_sequence_plan(request, Source::render, 2, d / "plan.json", {});
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  for (int i = 0; i < 2; ++i) ASSERT_TRUE(run_sequence_shard(*plan, i, {}).ok());
  auto merged = merge_sequence_plan(*plan, d / "merged");
  ASSERT_TRUE(merged.ok()) << merged.error().message;
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(bytes_of(d / fmt::format("merged.{:05d}.raw", i)), bytes_of(d / fmt::format("one.{:05d}.raw", i)));
  EXPECT_EQ(merged->sidecar["frames"], one->sidecar["frames"]);
}

}  // namespace
}  // namespace hdrd::job

// `hdrd encode 'shot.%d.exr' --video ...` and `hdrd render --frames` end to end, checked with
// third-party tools: ffprobe for codec, profile, pixel format, H.273 colour tags and the
// mastering / content-light / HDR10+ side data; ffmpeg's decoder for the pictures, whose
// Y' in lossless mode is the BT.2020 (non-constant luminance) Y' of the per-frame raw dumps,
// computed here from the equations (BT.2020 Table 4, BT.2100 narrow-range quantisation);
// the HDR10+ JSON against ST 2094-40's ranges; and the command line's contract (one line on
// error, nothing left behind, --json is the sidecar).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "tests/testing/ffprobe.hpp"
#include "tests/testing/testing.hpp"

namespace fs = std::filesystem;
using hdrd::testing::run_command;
using hdrd::testing::side_data;
using hdrd::testing::TempDir;
using nlohmann::json;

namespace {

constexpr int kW = 64, kH = 32;

std::string hdrd() { return hdrd::testing::hdrd_binary().string(); }
bool have(const char* tool) { return hdrd::testing::have_tool(tool); }

// Shots of a moving gradient (a different picture each frame), relative Rec.709.
void write_shots(const fs::path& dir, int n, double gain = 1.0) {
  for (int i = 0; i < n; ++i) {
    hdrd::Image img(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        float* p = img.rgba.data() + (static_cast<std::size_t>(y) * kW + x) * 4;
        const double u = std::fmod((x + 3.0 * i) / kW, 1.0);
        p[0] = static_cast<float>(gain * 4 * u * u);
        p[1] = static_cast<float>(gain * (0.1 + 0.8 * y / kH));
        p[2] = static_cast<float>(gain * 2 * (1 - u));
      }
    ASSERT_TRUE(hdrd::io::write_exr(dir / fmt::format("s.{}.exr", i), img, {}).ok());
  }
}

json ffprobe(const fs::path& file) {
  auto j = hdrd::testing::ffprobe(file);
  EXPECT_TRUE(j) << "ffprobe failed on " << file;
  return j ? *j : json::object();
}

std::vector<std::uint8_t> slurp(const fs::path& p) {
  const std::string s = hdrd::testing::read_file(p);
  return {s.begin(), s.end()};
}

TEST(SequenceCli, LosslessHevcCarriesTheDumpsYPrimeAndItsTags) {
  if (!have("ffprobe") || !have("ffmpeg")) GTEST_SKIP() << "ffprobe/ffmpeg missing (apt-get install ffmpeg)";
  TempDir d;
  write_shots(d.path(), 6);
  const fs::path out = d / "seq";
  const auto r = run_command(fmt::format("'{}' encode '{}' --mode hdr10 --peak 1000 --video hevc --video-lossless "
                                         "--format raw --fps 30 -o '{}' --json",
                                         hdrd(), (d / "s.%d.exr").string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json sidecar = json::parse(r.out);
  EXPECT_EQ(sidecar["format"], "hdrd-sequence");
  EXPECT_EQ(sidecar, json::parse(hdrd::testing::read_file(d / "seq.json")));
  ASSERT_EQ(sidecar["frames"].size(), 6u);
  EXPECT_EQ(sidecar["files"]["video"], "seq.mp4");
  EXPECT_EQ(sidecar["files"]["frames"]["raw"], "seq.%05d.raw");

  const json probe = ffprobe(d / "seq.mp4");
  ASSERT_EQ(probe["streams"].size(), 1u);
  const json& st = probe["streams"][0];
  EXPECT_EQ(st["codec_name"], "hevc");
  EXPECT_EQ(st["profile"], "Main 10");
  EXPECT_EQ(st["pix_fmt"], "yuv420p10le");
  EXPECT_EQ(st["color_primaries"], "bt2020");
  EXPECT_EQ(st["color_transfer"], "smpte2084");
  EXPECT_EQ(st["color_space"], "bt2020nc");
  EXPECT_EQ(st["color_range"], "tv");
  EXPECT_EQ(st["r_frame_rate"], "30/1");
  ASSERT_EQ(probe["frames"].size(), 6u);
  const json& f0 = probe["frames"][0];
  const json* mdcv = side_data(f0, "Mastering display metadata");
  const json* clli = side_data(f0, "Content light level metadata");
  ASSERT_TRUE(mdcv && clli) << f0.dump();
  EXPECT_EQ((*clli)["max_content"].get<double>(), sidecar["content_light_level"]["max_cll_nits"].get<double>());
  EXPECT_EQ((*clli)["max_average"].get<double>(), sidecar["content_light_level"]["max_fall_nits"].get<double>());
  EXPECT_EQ((*mdcv)["max_luminance"], "10000000/10000");  // ST 2086 from the target: 1000 cd/m2
  for (const auto& f : probe["frames"])
    EXPECT_NE(side_data(f, "HDR Dynamic Metadata SMPTE2094-40 (HDR10+)"), nullptr) << "HDR10+ in every frame";

  // Decoded Y' against the BT.2020 equations on each per-frame raw dump (XB30: full-range
  // 10-bit R'G'B' PQ codes, R in bits 0-9): Y' = 0.2627 R' + 0.6780 G' + 0.0593 B',
  // narrow-range code = round((219 Y' + 16) * 4).
  const fs::path yuv = d / "decoded.yuv";
  ASSERT_EQ(run_command(fmt::format("ffmpeg -v error -i '{}' -f rawvideo -pix_fmt yuv420p10le '{}'",
                                    (d / "seq.mp4").string(), yuv.string()))
                .exit_code,
            0);
  const auto decoded = slurp(yuv);
  const std::size_t frame_bytes = kW * kH * 2 * 3 / 2;
  ASSERT_EQ(decoded.size(), 6 * frame_bytes);
  for (int i = 0; i < 6; ++i) {
    const auto raw = slurp(d / fmt::format("seq.{:05d}.raw", i));
    ASSERT_EQ(raw.size(), static_cast<std::size_t>(kW * kH * 4));
    int worst = 0;
    for (int p = 0; p < kW * kH; ++p) {
      const std::uint32_t v = raw[p * 4] | raw[p * 4 + 1] << 8 | raw[p * 4 + 2] << 16 |
                              static_cast<std::uint32_t>(raw[p * 4 + 3]) << 24;
      const double r = (v & 1023) / 1023.0, g = (v >> 10 & 1023) / 1023.0, b = (v >> 20 & 1023) / 1023.0;
      const double y = 0.2627 * r + 0.6780 * g + 0.0593 * b;
      const int expected = static_cast<int>(std::lround((219 * y + 16) * 4));
      const std::size_t at = i * frame_bytes + static_cast<std::size_t>(p) * 2;
      const int got = decoded[at] | decoded[at + 1] << 8;
      worst = std::max(worst, std::abs(got - expected));
    }
    EXPECT_LE(worst, 1) << "frame " << i << ": decoded Y' off the equations by " << worst << " codes";
  }
}

// Issue 29 item 4: SDR video is tagged BT.709 (transfer 1, BT.1886 display) by default, as
// players expect, not sRGB (13); --sdr-video-transfer srgb keeps 13. ffprobe reads the tags.
TEST(SequenceCli, SdrVideoIsBt709ByDefault) {
  if (!have("ffprobe")) GTEST_SKIP() << "ffprobe missing (apt-get install ffmpeg)";
  TempDir d;
  write_shots(d.path(), 3);
  const std::pair<const char*, const char*> cases[] = {{"", "bt709"}, {" --sdr-video-transfer srgb", "iec61966-2-1"}};
  for (const auto& [flag, want] : cases) {
    const fs::path out = d / "sdr";
    const auto r = run_command(fmt::format("'{}' encode '{}' --mode sdr --video hevc --preset ultrafast --format raw "
                                           "-o '{}' --json -q{}",
                                           hdrd(), (d / "s.%d.exr").string(), out.string(), flag));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const json probe = ffprobe(d / "sdr.mp4");
    ASSERT_EQ(probe["streams"].size(), 1u);
    EXPECT_EQ(probe["streams"][0]["color_transfer"], want) << flag;
    EXPECT_EQ(probe["streams"][0]["color_primaries"], "bt709");
    const json sidecar = json::parse(r.out);
    EXPECT_EQ(sidecar["video"]["transfer_characteristics"], std::string(want) == "bt709" ? 1 : 13) << flag;
    const json frame = json::parse(hdrd::testing::read_file(d / "sdr.00000.json"));
    EXPECT_EQ(frame["transfer"], std::string(want) == "bt709" ? "bt1886" : "srgb") << flag;
  }
}

// Issue 29 item 5: a keyframe at every detected scene cut with the default AV1 encoder
// (SVT-AV1, which ignored the request: one keyframe, frame 0), libaom and HEVC alike. Five
// scenes of three 64x64 frames, 4 stops apart; ffprobe's key_frame flags against the
// sidecar's scenes.
TEST(SequenceCli, EveryVideoEncoderPutsAKeyframeAtEverySceneCut) {
  if (!have("ffprobe")) GTEST_SKIP() << "ffprobe missing (apt-get install ffmpeg)";
  TempDir d;
  const double gains[5] = {1, 16, 1, 16, 1};
  for (int i = 0; i < 15; ++i) {
    hdrd::Image img(64, 64);
    for (std::size_t p = 0; p < img.pixel_count(); ++p)
      for (int c = 0; c < 3; ++c)
        img.rgba[p * 4 + c] = static_cast<float>(gains[i / 3] * (0.05 + 0.9 * static_cast<double>(p % 64) / 64) * (c + 1) / 3);
    ASSERT_TRUE(hdrd::io::write_exr(d / fmt::format("c.{}.exr", i), img, {}).ok());
  }
  const char* encoders[] = {"--video av1", "--video av1 --av1-encoder libaom-av1 --preset 8", "--video hevc --preset ultrafast"};
  for (const char* enc : encoders) {
    SCOPED_TRACE(enc);
    const auto r = run_command(fmt::format("'{}' encode '{}' --mode hdr10 {} --format raw -o '{}' --json -q", hdrd(),
                                           (d / "c.%d.exr").string(), enc, (d / "v").string()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const json sidecar = json::parse(r.out);
    std::set<int> starts;
    for (const auto& s : sidecar["scenes"]) starts.insert(s["first_frame"].get<int>());
    ASSERT_EQ(starts, (std::set<int>{0, 3, 6, 9, 12})) << sidecar["scenes"];
    const json probe = ffprobe(d / "v.mp4");
    ASSERT_EQ(probe["frames"].size(), 15u);
    for (int i : starts) EXPECT_EQ(probe["frames"][i]["key_frame"], 1) << "frame " << i << " starts a scene";
  }
}

TEST(SequenceCli, Hdr10PlusJsonIsWithinSt2094_40) {
  TempDir d;
  write_shots(d.path(), 4, 8.0);
  const auto r = run_command(fmt::format("'{}' encode '{}' --format raw -o '{}' -q", hdrd(), (d / "s.%d.exr").string(),
                                         (d / "seq").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(hdrd::testing::read_file(d / "seq.hdr10plus.json"));
  ASSERT_EQ(j["SceneInfo"].size(), 4u);
  int index = 0;
  for (const auto& s : j["SceneInfo"]) {
    EXPECT_EQ(s["SequenceFrameIndex"], index++);
    EXPECT_EQ(s["NumberOfWindows"], 1);
    const auto& lp = s["LuminanceParameters"];
    // ST 2094-40 §6.1: maxscl and average_maxrgb in 0.1 cd/m2, 0..100000; distribution
    // percentages 1..99 increasing, values non-decreasing within 0..100000.
    for (const auto& m : lp["MaxScl"]) EXPECT_TRUE(m >= 0 && m <= 100000) << m;
    EXPECT_TRUE(lp["AverageRGB"] >= 0 && lp["AverageRGB"] <= 100000);
    const auto& idx = lp["LuminanceDistributions"]["DistributionIndex"];
    const auto& val = lp["LuminanceDistributions"]["DistributionValues"];
    ASSERT_EQ(idx.size(), val.size());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      EXPECT_TRUE(idx[k] >= 0 && idx[k] <= 100);
      EXPECT_TRUE(val[k] >= 0 && val[k] <= 100000);
      if (k > 0) {
        EXPECT_GT(idx[k].get<int>(), idx[k - 1].get<int>());
        EXPECT_GE(val[k].get<int>(), val[k - 1].get<int>());
      }
    }
    const int max_scl = std::max({lp["MaxScl"][0].get<int>(), lp["MaxScl"][1].get<int>(), lp["MaxScl"][2].get<int>()});
    EXPECT_LE(lp["AverageRGB"].get<int>(), max_scl);
    EXPECT_TRUE(s["TargetedSystemDisplayMaximumLuminance"] >= 0 && s["TargetedSystemDisplayMaximumLuminance"] <= 10000);
  }
}

// Issue 29 item 15: an EXR sequence's summary said "render 0.0 ms" and never the read time.
// Its per-frame line names the stages it ran: read, not render.
TEST(SequenceCli, ExrSequenceSummaryGivesTheReadTimeAndNoRender) {
  TempDir d;
  write_shots(d.path(), 3);
  const auto r = run_command(fmt::format("'{}' encode '{}' --mode hdr10 --format raw -o '{}'", hdrd(),
                                         (d / "s.%d.exr").string(), (d / "seq").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto line = r.err.find("per frame: ");
  ASSERT_NE(line, std::string::npos) << r.err;
  const std::string per_frame = r.err.substr(line, r.err.find('\n', line) - line);
  EXPECT_NE(per_frame.find("read "), std::string::npos) << per_frame;
  EXPECT_EQ(per_frame.find("render"), std::string::npos) << per_frame;
}

TEST(SequenceCli, ErrorsAreOneLineAndLeaveNothing) {
  TempDir d;
  fs::create_directory(d / "in");
  write_shots(d / "in", 2);
  fs::create_directory(d / "out");
  struct Case {
    std::string args, expected;
  };
  std::vector<Case> cases = {
      {"encode '" + (d / "in" / "nothing.%d.exr").string() + "' --video hevc", "no file matches"},
      {"encode '" + (d / "in" / "s.%d.exr").string() + "' --frames 3", "frames: 3 asked"},
      {"encode '" + (d / "in" / "s.%d.exr").string() + "' --video h264 --mode hdr10", "H.264 video is for SDR only"},
      {"encode '" + (d / "in" / "s.%d.exr").string() + "' --video vp9", "--video"},
      {"encode '" + (d / "in" / "s.%d.exr").string() + "' --fps 0", "--fps"},
      {"pattern bt2111 --frames 3", "frames"},
  };
  // Live output on a machine without a display: the sequence stops at its first frame.
  if (!fs::exists("/dev/dri"))
    cases.push_back({"render --scene furnace --width 32 --height 16 --samples 1 --frames 2 --present", "no display attached"});
  for (const auto& c : cases) {
    const auto r = run_command(fmt::format("'{}' {} -o '{}' -q", hdrd(), c.args, (d / "out" / "x").string()));
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << ": " << r.err;
    EXPECT_TRUE(fs::is_empty(d / "out")) << c.args;
  }
}

// Issues 28.7 and 29.13: what the settings cannot do is refused before any work, by the
// check the daemon makes before its 202 (job::check_request), in one line that names the
// setting. It was found at frame 0, after rendering it, as `frame 0 (t = 0 s): cannot open
// libx265: Invalid argument` (64x8, 256x2), `frame 0 (t = 0 s): 4:2:0 video needs ...` and
// the like; a missing output directory only when the first file was written.
TEST(SequenceCli, SettingErrorsNameTheSettingBeforeAnyWork) {
  TempDir d;
  fs::create_directory(d / "out");
  const std::string render = "render --scene furnace --samples 1 ";
  struct Case {
    std::string args, outbase, setting;
  };
  const std::string out = (d / "out" / "x").string(), missing = (d / "out" / "none" / "x").string();
  const std::vector<Case> cases = {
      {render + "--width 64 --height 8 --frames 2 --video hevc", out, "--width/--height: x265 needs"},
      {render + "--width 256 --height 2 --frames 2 --video hevc", out, "--width/--height: x265 needs"},
      {render + "--width 65 --height 32 --frames 2 --video hevc", out, "--width/--height: 4:2:0 video"},
      {render + "--width 64 --height 32 --frames 2 --video h264 --mode hdr10", out, "--video: H.264 video is for SDR only"},
      {render + "--width 64 --height 32 --frames 2 --video hevc", missing, "-o: "},
      {render + "--width 64 --height 32", missing, "-o: "},  // a single frame too
  };
  for (const auto& c : cases) {
    const auto r = run_command(fmt::format("'{}' {} -o '{}'", hdrd(), c.args, c.outbase));
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_EQ(r.err.rfind("hdrd: error: " + c.setting, 0), 0u) << c.args << ": " << r.err;
    EXPECT_EQ(r.err.find("frame 0"), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << ": nothing ran before: " << r.err;
    EXPECT_TRUE(fs::is_empty(d / "out")) << c.args;
  }
}

TEST(SequenceCli, RenderSequenceOfAStillSceneIsSteady) {
  TempDir d;
  const auto r = run_command(fmt::format("'{}' render --scene furnace --width 48 --height 32 --samples 1 --frames 3 "
                                         "--format raw -o '{}' -q --json",
                                         hdrd(), (d / "r").string()));
  if (r.exit_code != 0 && r.err.find("render.") != std::string::npos) GTEST_SKIP() << "no GL renderer: " << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  ASSERT_EQ(j["frames"].size(), 3u);
  EXPECT_DOUBLE_EQ(j["frames"][2]["time_s"].get<double>(), 2.0 / 24);
  EXPECT_EQ(slurp(d / "r.00000.raw"), slurp(d / "r.00002.raw"));
  EXPECT_EQ(j["frames"][0]["exposure_scale"], j["frames"][2]["exposure_scale"]);
}

// issue 20: the same sequence in one process and as shards in separate processes (plan,
// one `run` per shard, all at once, then merge) gives the same per-frame dumps and the same
// decisions, metadata and sidecar (less timings), and a lossless video with the same pictures.
TEST(SequenceCli, ShardsInSeparateProcessesMergeIntoTheOneProcessResult) {
  if (!have("ffmpeg")) GTEST_SKIP() << "ffmpeg missing (apt-get install ffmpeg): the pictures are compared with it";
  TempDir d;
  write_shots(d.path(), 9, 2.0);
  const std::string seq = fmt::format("encode '{}' --exposure-mode histogram --adaptation 0.3 --video hevc "
                                      "--video-lossless --preset ultrafast --format raw",
                                      (d / "s.%d.exr").string());
  ASSERT_EQ(run_command(fmt::format("'{}' {} -o '{}' -q", hdrd(), seq, (d / "one").string())).exit_code, 0);
  const auto plan = run_command(fmt::format("'{}' sequence plan --shards 3 -o '{}' -q --json {}", hdrd(),
                                            (d / "plan.json").string(), seq));
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  EXPECT_EQ(json::parse(plan.out)["shards"], 3);
  std::string shards;  // three processes at once, as an engine starts them
  for (int i = 0; i < 3; ++i)
    shards += fmt::format("'{}' sequence run '{}' --shard {} -q & ", hdrd(), (d / "plan.json").string(), i);
  ASSERT_EQ(run_command("set -e; " + shards + "wait %1 && wait %2 && wait %3").exit_code, 0);
  const auto merge = run_command(fmt::format("'{}' sequence merge '{}' -o '{}' -q --json", hdrd(),
                                             (d / "plan.json").string(), (d / "merged").string()));
  ASSERT_EQ(merge.exit_code, 0) << merge.err;
  for (int i = 0; i < 9; ++i)
    EXPECT_EQ(slurp(d / fmt::format("merged.{:05d}.raw", i)), slurp(d / fmt::format("one.{:05d}.raw", i))) << i;
  json a = json::parse(hdrd::testing::read_file(d / "merged.json")), b = json::parse(hdrd::testing::read_file(d / "one.json"));
  for (json* j : {&a, &b}) {
    j->erase("timings_ms");
    (*j)["video"].erase("bytes");
    (*j)["video"].erase("file");
    j->erase("files");
  }
  EXPECT_EQ(a, b);
  auto pictures = [&](const char* base) {
    const fs::path yuv = d / fmt::format("{}.yuv", base);
    EXPECT_EQ(run_command(fmt::format("ffmpeg -v error -i '{}' -f rawvideo -pix_fmt yuv420p10le '{}'",
                                      (d / fmt::format("{}.mp4", base)).string(), yuv.string()))
                  .exit_code,
              0);
    return slurp(yuv);
  };
  EXPECT_TRUE(pictures("merged") == pictures("one"));
  // A merge that lacks a shard says which, and writes nothing.
  fs::remove(d / "plan.json.d" / "shard-1.done");
  const auto again = run_command(fmt::format("'{}' sequence merge '{}' -o '{}' -q", hdrd(), (d / "plan.json").string(),
                                             (d / "again").string()));
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("shard 1 of 3 is missing"), std::string::npos) << again.err;
  EXPECT_FALSE(fs::exists(d / "again.mp4"));
}

}  // namespace

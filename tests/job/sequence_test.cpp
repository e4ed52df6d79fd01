// The sequence job (job/sequence.hpp): frame inputs (patterns, directories, lists), the
// temporal decisions seen through its outputs (manual exposure = each frame's single-frame
// encode, a static scene gives identical frames, a cut resets adaptation, the step response
// follows the exponential model computed here), sequence MaxCLL/MaxFALL recomputed from the
// decoded raw frames with the PQ EOTF (ST 2084, tests/testing/standards.hpp), all or
// nothing on errors, and every sequence setting read.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "job/frame_job.hpp"
#include "job/sequence.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/standards.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::job {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kW = 32, kH = 16;

ParseContext context(Source source, bool sequence) {
  ParseContext ctx;
  ctx.source = source;
  ctx.spelling = Spelling::json;
  ctx.reach = Reach::cli;
  ctx.sequence = sequence;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<fs::path> { return fs::path(p); };
  return ctx;
}

// A relative EXR: a ramp times `gain` (a brighter shot for larger gains).
void write_shot(const fs::path& p, double gain, int w = kW, int h = kH) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.rgba[(static_cast<std::size_t>(y) * w + x) * 4 + c] =
            static_cast<float>(gain * 0.02 * (x + 1) * (1 + 0.3 * c) * (1 + 0.05 * y));
  ASSERT_TRUE(io::write_exr(p, img, {}).ok());
}

FrameRequest parse(const json& body, Source source, bool sequence) {
  auto r = parse_request_json(body, context(source, sequence));
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : FrameRequest{};
}

Result<SequenceResult> run(const json& body, const fs::path& outbase, SequenceOptions options = {}) {
  auto r = parse_request_json(body, context(Source::encode, true));
  if (!r) return r.error();
  return run_sequence(*r, outbase, options);
}

// The raw frame of a single-frame encode of `exr` with `body`'s settings.
std::vector<std::uint8_t> single_frame_raw(json body, const fs::path& exr) {
  body.erase("images");
  if (body.contains("exposure")) body["exposure"].erase("adaptation_time_s");  // a sequence setting
  body["formats"] = {"raw"};
  auto job = FrameJob::create(parse(body, Source::encode, false), {}, EncodeInput{exr, {}, ""});
  EXPECT_TRUE(job.ok());
  auto r = run_frame_job(**job);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? r->frame.data : std::vector<std::uint8_t>{};
}

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
  const std::string s = testing::read_file(p);
  return {s.begin(), s.end()};
}

json read_json(const fs::path& p) { return json::parse(testing::read_file(p)); }

// ---- inputs ------------------------------------------------------------------------------

TEST(SequenceInputs, PatternTakesConsecutiveNumbersFromTheLowest) {
  testing::TempDir d;
  for (int i : {7, 8, 9, 10}) std::ofstream(d / fmt::format("shot.{:04d}.exr", i)) << "x";
  std::ofstream(d / "shot.12345.exr") << "x";  // more digits than %04d writes with a leading digit: 12345 is a frame
  std::ofstream(d / "shot.0011.exr.bak") << "x";
  std::ofstream(d / "other.0011.exr") << "x";
  auto files = exr_sequence_files(d / "shot.%04d.exr");
  ASSERT_FALSE(files.ok());  // 11..12344 missing
  EXPECT_NE(files.error().message.find("frame 11 is missing"), std::string::npos) << files.error().message;
  fs::remove(d / "shot.12345.exr");
  files = exr_sequence_files(d / "shot.%04d.exr");
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 4u);
  EXPECT_EQ(files->front().filename(), "shot.0007.exr");
  EXPECT_EQ(files->back().filename(), "shot.0010.exr");
  EXPECT_TRUE(names_a_sequence(d / "shot.%04d.exr"));
  EXPECT_FALSE(names_a_sequence(d / "shot.0007.exr"));
}

TEST(SequenceInputs, PlainPercentDTakesNoLeadingZeros) {
  testing::TempDir d;
  for (int i : {1, 2, 3}) std::ofstream(d / fmt::format("f{}.exr", i)) << "x";
  std::ofstream(d / "f01.exr") << "x";  // not what %d writes
  auto files = exr_sequence_files(d / "f%d.exr");
  ASSERT_TRUE(files.ok()) << files.error().message;
  EXPECT_EQ(files->size(), 3u);
}

TEST(SequenceInputs, DirectoryAndListFile) {
  testing::TempDir d;
  fs::create_directory(d / "dir");
  for (const char* n : {"b.exr", "a.exr", "c.EXR", "notes.txt"}) std::ofstream(d / "dir" / n) << "x";
  auto files = exr_sequence_files(d / "dir");
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 3u);
  EXPECT_EQ((*files)[0].filename(), "a.exr");
  EXPECT_EQ((*files)[2].filename(), "c.EXR");
  std::ofstream(d / "list.txt") << "# shots\n dir/b.exr \n\n" << (d / "dir" / "a.exr").string() << "\r\n";
  files = exr_sequence_files(d / "list.txt");
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 2u);
  EXPECT_EQ((*files)[0], d.path() / "dir" / "b.exr");  // relative to the list
  EXPECT_EQ((*files)[1], d.path() / "dir" / "a.exr");
  std::ofstream(d / "empty.txt") << "# nothing\n";
  EXPECT_FALSE(exr_sequence_files(d / "empty.txt").ok());
  EXPECT_EQ(exr_sequence_files(d / "nothing.%03d.exr").error().code, "input.sequence");
  EXPECT_EQ(exr_sequence_files(d / "dir" / "a.exr").error().code, "input.sequence");
}

TEST(SequenceRequest, SequenceSettingsExistOnlyInSequences) {
  auto r = parse_request_json(json{{"frames", 3}}, context(Source::encode, false));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.unknown_field");
  EXPECT_NE(r.error().message.find("sequence"), std::string::npos);
  EXPECT_TRUE(sets_sequence_settings(json{{"video", {{"codec", "hevc"}}}}));
  EXPECT_TRUE(sets_sequence_settings(json{{"exposure", {{"adaptation_time_s", 1}}}}));
  EXPECT_FALSE(sets_sequence_settings(json{{"exposure", {{"mode", "manual"}}}, {"video", 1}}));
  // A single frame's canonical request has no sequence settings (its sidecar is unchanged).
  const json c = parse(json::object(), Source::encode, false).canonical();
  EXPECT_FALSE(c.contains("frames"));
  EXPECT_FALSE(c.contains("video"));
}

// ---- the time axis -----------------------------------------------------------------------

// Defaults from the settings table: the exposure falls into the light three times faster
// than it rises into the dark (Unreal's speed up 3, down 1; the eye adapts to light in
// seconds, to the dark far slower), each an exponential in stops solved exactly per frame
// interval, so 24 and 48 fps give the same exposure after the same time. The reference is
// the closed form log2 S(t) = log2 T + (log2 S0 - log2 T) exp(-(t - t0) / tau), computed here.
TEST(SequenceRequest, AdaptationDefaultsDifferByDirectionAndIgnoreTheFrameRate) {
  const temporal::TemporalSettings t = temporal_settings(parse(json::object(), Source::render, true));
  EXPECT_DOUBLE_EQ(t.adaptation.brighten_time_s, 1.0);
  EXPECT_NEAR(t.adaptation.darken_time_s, 1.0 / 3, 1e-3);
  const auto both = temporal_settings(parse(json{{"exposure", {{"adaptation_time_s", 2}}}}, Source::render, true));
  EXPECT_EQ(both.adaptation.brighten_time_s, 2.0);
  EXPECT_EQ(both.adaptation.darken_time_s, 2.0);
  const auto one = temporal_settings(
      parse(json{{"exposure", {{"adaptation_time_s", 2}, {"adaptation_darken_time_s", 0.5}}}}, Source::render, true));
  EXPECT_EQ(one.adaptation.brighten_time_s, 2.0);
  EXPECT_EQ(one.adaptation.darken_time_s, 0.5);

  // A step of the metered scale at t0 = 0.5 s (on both frame grids), read at t = 1.5 s.
  const double s0 = 1.0, s1 = 1.0 / 64, t0 = 0.5, t_end = 1.5;
  auto adapted = [&](double fps, double from, double to) {
    temporal::ExposureAdaptation a(t.adaptation);
    double v = 0;
    const int frames = static_cast<int>(std::lround(t_end * fps));
    for (int k = 0; k <= frames; ++k) v = *a.next(k < std::lround(t0 * fps) ? from : to, 1.0 / fps, k == 0);
    return std::log2(v);
  };
  auto closed_form = [&](double from, double to, double tau) {
    return std::log2(to) + (std::log2(from) - std::log2(to)) * std::exp(-(t_end - t0) / tau);
  };
  const double into_light = closed_form(s0, s1, t.adaptation.darken_time_s);
  const double into_dark = closed_form(s1, s0, t.adaptation.brighten_time_s);
  for (double fps : {24.0, 48.0}) {
    EXPECT_NEAR(adapted(fps, s0, s1), into_light, 1e-9) << fps << " fps, into the light";
    EXPECT_NEAR(adapted(fps, s1, s0), into_dark, 1e-9) << fps << " fps, into the dark";
  }
  EXPECT_NEAR(adapted(24, s0, s1), adapted(48, s0, s1), 1e-9);
  // 1 s after the step: 95 % of the 6 stops into the light, 63 % into the dark.
  EXPECT_NEAR((std::log2(s0) - into_light) / 6, 1 - std::exp(-3.0), 2e-3);
  EXPECT_NEAR((into_dark - std::log2(s1)) / 6, 1 - std::exp(-1.0), 1e-9);
}

TEST(Sequence, ManualExposureGivesEachFrameItsSingleFrameEncode) {
  testing::TempDir d;
  for (int i = 0; i < 4; ++i) write_shot(d / fmt::format("s.{}.exr", i), std::pow(2.0, 2 * i));
  const json body = {{"images", (d / "s.%d.exr").string()},
                     {"exposure", {{"mode", "manual"}, {"adaptation_time_s", 2}}},
                     {"formats", {"raw"}}};
  auto r = run(body, d / "out");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->frames, 4);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(read_bytes(d / fmt::format("out.{:05d}.raw", i)), single_frame_raw(body, d / fmt::format("s.{}.exr", i)))
        << "frame " << i;
}

TEST(Sequence, StaticSceneFramesAreIdentical) {
  testing::TempDir d;
  for (int i = 0; i < 5; ++i) write_shot(d / fmt::format("s.{}.exr", i), 4.0);
  const json body = {{"images", (d / "s.%d.exr").string()},
                     {"exposure", {{"mode", "histogram"}, {"adaptation_time_s", 1}}},
                     {"tone", {{"curve", "bt2390"}}},
                     {"formats", {"raw"}}};
  auto r = run(body, d / "out");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto first = read_bytes(d / "out.00000.raw");
  ASSERT_EQ(first.size(), static_cast<std::size_t>(kW * kH * 4));
  for (int i = 1; i < 5; ++i) EXPECT_EQ(read_bytes(d / fmt::format("out.{:05d}.raw", i)), first) << "frame " << i;
  const json& frames = r->sidecar["frames"];
  for (const auto& f : frames) EXPECT_EQ(f["exposure_scale"], frames[0]["exposure_scale"]);
  EXPECT_EQ(r->sidecar["scenes"].size(), 1u);
}

// Three frames of a dim shot, then a shot 6 stops brighter.
struct CutSequence {
  testing::TempDir d;
  CutSequence() {
    for (int i = 0; i < 3; ++i) write_shot(d / fmt::format("s.{}.exr", i), 0.25);
    for (int i = 3; i < 8; ++i) write_shot(d / fmt::format("s.{}.exr", i), 16.0);
  }
  json body(bool detect_cuts, double tau_s) const {
    return {{"images", (d / "s.%d.exr").string()},
            {"fps", 10},
            {"exposure", {{"mode", "histogram"}, {"adaptation_time_s", tau_s}}},
            {"sequence", {{"detect_cuts", detect_cuts}}},
            {"formats", {"raw"}}};
  }
  // The exposure scale a single frame of that shot is metered to.
  double own_scale(int frame) const {
    json b = body(true, 0);
    b.erase("images");
    b.erase("fps");
    b.erase("sequence");
    b["exposure"].erase("adaptation_time_s");
    auto job = FrameJob::create(parse(b, Source::encode, false), {}, EncodeInput{d / fmt::format("s.{}.exr", frame), {}, ""});
    auto r = run_frame_job(**job);
    return r->frame.settings["exposure"]["scale"].get<double>();
  }
};

TEST(Sequence, CutResetsAdaptation) {
  CutSequence s;
  auto r = run(s.body(true, 1.0), s.d / "out");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const json& scenes = r->sidecar["scenes"];
  ASSERT_EQ(scenes.size(), 2u) << scenes.dump();
  EXPECT_EQ(scenes[0], (json{{"first_frame", 0}, {"last_frame", 2}}));
  EXPECT_EQ(scenes[1], (json{{"first_frame", 3}, {"last_frame", 7}}));
  // The new scene's first frame is exposed from its own metering, as a single frame.
  EXPECT_EQ(read_bytes(s.d / "out.00003.raw"), single_frame_raw(json{{"exposure", {{"mode", "histogram"}}}}, s.d / "s.3.exr"));
  EXPECT_EQ(r->sidecar["frames"][3]["scene"], 1);
  EXPECT_TRUE(r->sidecar["frames"][3]["scene_start"].get<bool>());
}

TEST(Sequence, StepResponseFollowsTheExponentialInStops) {
  CutSequence s;
  const double tau = 0.4, dt = 0.1;
  auto r = run(s.body(false, tau), s.d / "out");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const double a = std::log2(s.own_scale(0)), b = std::log2(s.own_scale(3));
  ASSERT_GT(std::abs(a - b), 5.0);
  const json& frames = r->sidecar["frames"];
  ASSERT_EQ(r->sidecar["scenes"].size(), 1u);
  // RTR4 §8.2.2: frame n is exposed from frame n-1's metering, approaching it as
  // d(log2 S)/dt = (log2 T - log2 S) / tau, solved exactly over each frame interval.
  double expected = a;
  for (int n = 0; n < 8; ++n) {
    if (n >= 4) expected += (b - expected) * (1 - std::exp(-dt / tau));
    EXPECT_NEAR(std::log2(frames[n]["exposure_scale"].get<double>()), expected, 1e-9) << "frame " << n;
  }
}

TEST(Sequence, ContentLightRecomputedFromTheDecodedFrames) {
  testing::TempDir d;
  for (int i = 0; i < 3; ++i) write_shot(d / fmt::format("s.{}.exr", i), 2.0 + 6.0 * i);
  const json body = {{"images", (d / "s.%d.exr").string()},
                     {"display", {{"mode", "hdr10"}, {"peak_nits", 1000}}},
                     {"formats", {"raw"}}};
  auto r = run(body, d / "out");
  ASSERT_TRUE(r.ok()) << r.error().message;
  // XB30 (DRM_FORMAT_XBGR2101010): R in bits 0-9, G 10-19, B 20-29; full-range PQ codes.
  double max_cll = 0, max_fall = 0;
  for (int i = 0; i < 3; ++i) {
    const auto raw = read_bytes(d / fmt::format("out.{:05d}.raw", i));
    ASSERT_EQ(raw.size(), static_cast<std::size_t>(kW * kH * 4));
    double sum = 0;
    for (std::size_t p = 0; p < raw.size(); p += 4) {
      const std::uint32_t v = raw[p] | raw[p + 1] << 8 | raw[p + 2] << 16 | static_cast<std::uint32_t>(raw[p + 3]) << 24;
      const int code = std::max({static_cast<int>(v & 1023), static_cast<int>(v >> 10 & 1023), static_cast<int>(v >> 20 & 1023)});
      const double nits = testing::standard::pq_eotf(code / 1023.0);
      max_cll = std::max(max_cll, nits);
      sum += nits;
    }
    max_fall = std::max(max_fall, sum / (kW * kH));
  }
  const json& cll = r->sidecar["content_light_level"];
  EXPECT_NEAR(cll["max_cll_nits_measured"].get<double>(), max_cll, max_cll * 1e-3);
  EXPECT_NEAR(cll["max_fall_nits_measured"].get<double>(), max_fall, max_fall * 1e-3);
  EXPECT_EQ(cll["max_cll_nits"].get<double>(), std::ceil(cll["max_cll_nits_measured"].get<double>()));
  // Per frame, the same quantities of that frame alone; the sequence's are their maxima.
  double frame_max = 0;
  for (const auto& f : r->sidecar["frames"]) frame_max = std::max(frame_max, f["max_cll_nits"].get<double>());
  EXPECT_DOUBLE_EQ(frame_max, cll["max_cll_nits_measured"].get<double>());
  EXPECT_TRUE(fs::exists(d / "out.hdr10plus.json"));
  EXPECT_TRUE(fs::exists(d / "out.dovi.json"));
  EXPECT_EQ(read_json(d / "out.json")["frames"].size(), 3u);
  EXPECT_EQ(read_json(d / "out.00001.json")["format"], "hdrd-dump");
}

// A sequence loads its UI overlay and its grade once, with the first frame: the files can
// go after it (each frame is still its single-frame encode with both applied).
TEST(Sequence, UiAndGradeAreLoadedOncePerSequence) {
  testing::TempDir d;
  for (int i = 0; i < 3; ++i) write_shot(d / fmt::format("s.{}.exr", i), 1.0 + i);
  const fs::path lut = d / "warm.cube", ui = d / "ui.png";
  std::ofstream(lut) << "LUT_3D_SIZE 2\n0 0 0\n1 0 0\n0 0.9 0\n1 0.9 0\n0 0 0.8\n1 0 0.8\n0 0.9 0.8\n1 0.9 0.8\n";
  io::pngtest::Spec spec;
  spec.width = 2, spec.height = 2, spec.color_type = 6;
  const auto png = io::pngtest::encode(spec, {255, 255, 255, 255, 128, 128, 128, 64, 128, 128, 128, 64, 0, 0, 0, 0});
  std::ofstream(ui, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  const json body = {{"images", (d / "s.%d.exr").string()},
                     {"exposure", {{"mode", "manual"}}},
                     {"grade", {{"lut", lut.string()}}},
                     {"ui", {{"path", ui.string()}, {"x", 3}, {"y", 2}, {"scale", 2}}},
                     {"formats", {"raw"}}};
  std::vector<std::vector<std::uint8_t>> want;
  for (int i = 0; i < 3; ++i) want.push_back(single_frame_raw(body, d / fmt::format("s.{}.exr", i)));
  SequenceOptions o;
  o.progress = [&](const SequenceProgress&) {
    fs::remove(lut);
    fs::remove(ui);
  };
  auto r = run(body, d / "out", o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(fs::exists(lut));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(read_bytes(d / fmt::format("out.{:05d}.raw", i)), want[i]) << "frame " << i;
  EXPECT_NE(want[0], single_frame_raw({{"images", "x"}, {"exposure", {{"mode", "manual"}}}}, d / "s.0.exr"))
      << "the grade and the UI change the frame";
}

TEST(Sequence, AnErrorLeavesNothingBehind) {
  testing::TempDir d;
  fs::create_directory(d / "in");
  for (int i = 0; i < 3; ++i) write_shot(d / "in" / fmt::format("s.{}.exr", i), 1.0, 64, kH);  // x265: >= 64 wide
  write_shot(d / "in" / "s.3.exr", 1.0, 128, kH);  // another size: the video cannot take it
  fs::create_directory(d / "out");
  const json body = {{"images", (d / "in" / "s.%d.exr").string()}, {"video", {{"codec", "hevc"}}}, {"formats", {"png"}}};
  auto r = run(body, d / "out" / "seq");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("frame 3 (s.3.exr)"), std::string::npos) << r.error().message;
  EXPECT_TRUE(fs::is_empty(d / "out")) << fs::directory_iterator(d / "out")->path();
}

TEST(Sequence, CancellationStopsAndRemovesTheFrames) {
  testing::TempDir d;
  for (int i = 0; i < 6; ++i) write_shot(d / fmt::format("s.{}.exr", i), 1.0);
  fs::create_directory(d / "out");
  SequenceOptions o;
  int progress_calls = 0;
  o.progress = [&](const SequenceProgress& p) {
    ++progress_calls;
    EXPECT_EQ(p.frames_total, 6);
    EXPECT_EQ(p.frames_done, progress_calls);
  };
  std::atomic<int> checks{0};
  o.job.should_stop = [&] { return ++checks > 8; };
  auto r = run({{"images", (d / "s.%d.exr").string()}, {"formats", {"raw"}}}, d / "out" / "seq", o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.cancelled");
  EXPECT_TRUE(fs::is_empty(d / "out"));
}

TEST(Sequence, EverySequenceSettingIsRead) {
  testing::TempDir d;
  for (int i = 0; i < 2; ++i) write_shot(d / fmt::format("s.{}.exr", i), 1.0);
  auto req = parse_request_json(json{{"images", (d / "s.%d.exr").string()}, {"formats", {"raw"}}},
                                context(Source::encode, true));
  ASSERT_TRUE(req.ok());
  auto r = run_sequence(*req, d / "out", {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (const auto& s : settings())
    if (s.sequence && s.takes(Source::encode)) {
      EXPECT_TRUE(req->read.count(s.path)) << s.path << " is never read";
    }
}

// The hdr scene's walk from the dim room into the sunlit yard, with every default: the
// exposure follows the picture (histogram metering, adaptation on), so it falls by stops
// over the walk instead of staying the sun's. 7 frames of 32x18 at 1 fps.
TEST(SequenceRender, HdrWalkAdaptsWithDefaults) {
  testing::TempDir d;
  json body = {{"scene", "hdr"}, {"width", 32}, {"height", 18}, {"samples", 1}, {"fps", 1}, {"formats", {"raw"}}};
  auto r = parse_request_json(body, context(Source::render, true));
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto seq = run_sequence(*r, d / "out", {});
  if (!seq.ok() && seq.error().code.rfind("render", 0) == 0) GTEST_SKIP() << "no GL renderer: " << seq.error().message;
  ASSERT_TRUE(seq.ok()) << seq.error().message;
  const json& frames = seq->sidecar["frames"];
  ASSERT_EQ(frames.size(), 7u) << "6 s at 1 fps, both ends";
  double lo = 1e300, hi = 0;
  for (const auto& f : frames) {
    const double k = f["exposure_scale"].get<double>();
    lo = std::min(lo, k), hi = std::max(hi, k);
  }
  EXPECT_GT(std::log2(hi / lo), 3.0) << frames.dump();
  EXPECT_LT(frames[6]["exposure_scale"].get<double>(), frames[0]["exposure_scale"].get<double>() / 8)
      << "out in the yard, at least 3 stops less exposure than in the room";
}

}  // namespace
}  // namespace hdrd::job

namespace hdrd::job {
namespace {

// What a service checks before it accepts a sequence (202): no frame is made.
TEST(SequenceCheck, RefusesBeforeTheFirstFrame) {
  testing::TempDir d;
  for (int i = 0; i < 3; ++i) write_shot(d / fmt::format("s.{}.exr", i), 1.0, 64, 16);  // x265's smallest
  const std::string images = (d / "s.%d.exr").string();
  auto check = [&](json body) {
    body["images"] = images;
    auto r = parse_request_json(body, context(Source::encode, true));
    EXPECT_TRUE(r.ok());
    return check_sequence(*r);
  };
  auto ok = check(json{{"video", {{"codec", "hevc"}}}});
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->frames, 3);
  EXPECT_EQ(ok->inputs.size(), 3u);
  EXPECT_EQ(ok->target.mode, Mode::hdr10);
  auto h264 = check(json{{"video", {{"codec", "h264"}}}});
  ASSERT_FALSE(h264.ok());
  EXPECT_NE(h264.error().message.find("H.264"), std::string::npos) << h264.error().message;
  EXPECT_FALSE(check(json{{"frames", 4}}).ok());
  EXPECT_FALSE(check(json{{"display", {{"mode", "scrgb"}}}, {"video", {{"codec", "hevc"}}}}).ok());
  auto r = parse_request_json(json{{"scene", "furnace"}, {"width", 33}, {"height", 16}, {"video", {{"codec", "hevc"}}}},
                              context(Source::render, true));
  ASSERT_TRUE(r.ok());
  auto odd = check_sequence(*r);
  ASSERT_FALSE(odd.ok());
  EXPECT_EQ(odd.error().code, "video.size") << odd.error().message;
}

// An encode's frame size is its EXRs': the first one's header is read before the first
// frame, so a 4:2:0 video of odd-sized EXRs, or HEVC frames under x265's 16 rows, is refused
// up front (before, check_sequence assumed 64x64 and frame 0 failed after the 202).
TEST(SequenceCheck, AnEncodesSizeIsItsFirstExrs) {
  testing::TempDir d;
  auto check = [&](int w, int h, const char* codec) {
    const std::string stem = fmt::format("s{}x{}", w, h);
    for (int i = 0; i < 2; ++i) write_shot(d / fmt::format("{}.{}.exr", stem, i), 1.0, w, h);
    auto r = parse_request_json(json{{"images", (d / (stem + ".%d.exr")).string()}, {"video", {{"codec", codec}}}},
                                context(Source::encode, true));
    EXPECT_TRUE(r.ok());
    return check_sequence(*r);
  };
  auto odd = check(65, 32, "hevc");
  ASSERT_FALSE(odd.ok());
  EXPECT_EQ(odd.error().code, "video.size") << odd.error().message;
  EXPECT_NE(odd.error().message.find("65x32"), std::string::npos) << odd.error().message;
  auto flat = check(64, 8, "hevc");
  ASSERT_FALSE(flat.ok());
  EXPECT_EQ(flat.error().code, "video.size") << flat.error().message;
  EXPECT_TRUE(check(64, 32, "hevc").ok());
}

}  // namespace
}  // namespace hdrd::job

namespace hdrd::job {
namespace {

// A render sequence of an animated JSON scene (docs/scene-format.md "Keyframes"): without
// `frames` it covers the animation; the keyframed EV100 is each frame's camera exposure
// (exactly a single frame's at that time); a keyed camera cut starts a scene.
TEST(SequenceRender, KeyframedSceneDrivesTimeExposureAndCuts) {
  testing::TempDir d;
  const json scene = json::parse(R"({
    "hdrd_scene": 1,
    "camera": {"position": [0, 1, 5], "target": [0, 0, 0]},
    "materials": [{"name": "grey", "base_color": 0.5}],
    "lights": [{"type": "directional", "direction": [0, -1, -0.3], "illuminance_lux": 1000}],
    "objects": [{"type": "sphere", "material": "grey", "radius": 1}],
    "keyframes": {
      "camera": {"keys": [{"t": 0, "position": [0, 1, 5]}, {"t": 1.5, "position": [3, 1, 5], "cut": true}]},
      "exposure": [{"t": 0, "ev100": 6}, {"t": 2, "ev100": 10}]
    }})");
  const fs::path file = d / "anim.json";
  std::ofstream(file) << scene.dump();
  json body = {{"scene", file.string()}, {"width", 24}, {"height", 16}, {"samples", 1}, {"fps", 2}, {"formats", {"raw"}}};
  auto r = parse_request_json(body, context(Source::render, true));
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto seq = run_sequence(*r, d / "out", {});
  if (!seq.ok() && seq.error().code.rfind("render", 0) == 0) GTEST_SKIP() << "no GL renderer: " << seq.error().message;
  ASSERT_TRUE(seq.ok()) << seq.error().message;
  const json& frames = seq->sidecar["frames"];
  ASSERT_EQ(frames.size(), 5u) << "2 s at 2 fps, both ends";
  EXPECT_DOUBLE_EQ(frames[4]["time_s"].get<double>(), 2.0);
  // The cut keyed at t = 1.5 starts a scene at frame 3 (t = 1.5).
  EXPECT_TRUE(frames[3]["scene_start"].get<bool>());
  EXPECT_EQ(frames[3]["scene"], 1);
  // EV100 6 -> 10 linearly: frame at t = 1 exposed as a single camera frame at EV100 8.
  auto single = parse_request_json(json{{"scene", file.string()}, {"width", 24}, {"height", 16}, {"samples", 1},
                                        {"exposure", {{"ev100", 8}}}, {"formats", {"raw"}}},
                                   context(Source::render, false));
  ASSERT_TRUE(single.ok());
  JobOptions at1;
  at1.time_s = 1.0;
  auto job = FrameJob::create(*single, at1);
  ASSERT_TRUE(job.ok());
  auto one = run_frame_job(**job);
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_EQ(read_bytes(d / "out.00002.raw"), one->frame.data);
  EXPECT_LT(frames[4]["exposure_scale"].get<double>(), frames[0]["exposure_scale"].get<double>() / 15)
      << "4 stops less exposure at EV100 10 than at 6";
}

}  // namespace
}  // namespace hdrd::job

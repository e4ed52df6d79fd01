// The frame job: every setting a request can carry is used (none is parsed and then
// ignored), the rules it decides once (exposure, encoder, outputs) and its all-or-nothing
// outputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "encode/io/io.hpp"
#include "job/build.hpp"
#include "job/frame_job.hpp"
#include "shading/renderer.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::job {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

ParseContext cli_context(Source source) {
  ParseContext ctx;
  ctx.source = source;
  ctx.spelling = Spelling::cli;
  ctx.reach = Reach::cli;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<fs::path> { return fs::path(p); };
  return ctx;
}

// A 16x8 relative EXR with a ramp, a UI PNG and an identity LUT, written by the test.
struct Inputs {
  testing::TempDir dir;
  fs::path exr = dir / "in.exr", ui = dir / "ui.png", lut = dir / "identity.cube";
  Inputs() {
    Image img(16, 8);
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 16; ++x)
        for (int c = 0; c < 3; ++c) img.rgba[(static_cast<std::size_t>(y) * 16 + x) * 4 + c] = 0.05f * (x + 1) * (c + 1);
    EXPECT_TRUE(io::write_exr(exr, img, {}).ok());
    std::ofstream(lut) << "LUT_3D_SIZE 2\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n";
    // 2x2 RGBA, straight alpha: one opaque white pixel, the rest translucent grey.
    io::pngtest::Spec spec;
    spec.width = 2, spec.height = 2, spec.color_type = 6;
    const auto png = io::pngtest::encode(spec, {255, 255, 255, 255, 128, 128, 128, 64, 128, 128, 128, 64, 0, 0, 0, 0});
    std::ofstream(ui, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  }
};

// The settings the frame job itself must read for `source`: all but the ones a front end
// reads (transport: dump, name, timeout, threads, backend) and those whose parsed form
// travels outside the value table (the scene reference, the uploaded UI bytes).
std::vector<std::string> job_settings(Source source) {
  std::vector<std::string> out;
  for (const auto& s : settings())
    if (s.takes(source) && s.reach == Reach::everywhere && s.type != Type::scene && s.type != Type::base64)
      out.emplace_back(s.path);
  return out;
}

void expect_all_read(const FrameRequest& r, Source source) {
  for (const auto& path : job_settings(source)) EXPECT_TRUE(r.read.count(path)) << path << " is parsed but never used";
}

json everything(const Inputs& in) {
  return json::parse(fmt::format(R"({{
    "display": {{"mode": "hdr10", "peak_nits": 800, "black_nits": 0.01, "paper_white_nits": 180, "ui_white_nits": 150,
                 "sdr_white_nits": 160, "range": "full", "bits": 10, "sdr_curve": "srgb"}},
    "tone": {{"curve": "reinhard", "apply": "luminance"}}, "gamut": "clip",
    "exposure": {{"mode": "manual", "compensation_ev": 0.5, "gain": 1.5, "percentile": 40}},
    "ui": {{"path": "{}", "x": 1, "y": 1, "scale": 2, "blend": "linear", "dim": 0.25, "premultiplied": false}},
    "grade": {{"lut": "{}", "placement": "display", "trilinear": true}},
    "formats": ["raw"], "dither": false}})",
                                 in.ui.string(), in.lut.string()));
}

TEST(FrameJob, EncodeUsesEverySettingItTakes) {
  Inputs in;
  auto r = parse_request_json(everything(in), cli_context(Source::encode));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EncodeInput input;
  input.path = in.exr;
  auto job = FrameJob::create(std::move(*r), {}, input);
  ASSERT_TRUE(job.ok()) << job.error().message;
  auto result = run_frame_job(**job);
  ASSERT_TRUE(result.ok()) << result.error().message;
  expect_all_read((*job)->request(), Source::encode);
  EXPECT_EQ(result->frame.target.peak_nits, 800);
  EXPECT_EQ(result->frame.target.ui_white_nits, 150);
  ASSERT_EQ(result->files.size(), 1u);
  EXPECT_EQ(result->files[0].id, Output::raw);
}

TEST(FrameJob, PatternUsesEverySettingItTakes) {
  for (const char* body : {R"({"pattern":"window","width":32,"height":16,"params":{"level_nits":400,"area_percent":25}})",
                           R"({"pattern":"pq-ramp","width":32,"height":16,"params":{"steps":4,"labels":false}})"}) {
    auto r = parse_request_json(json::parse(body), cli_context(Source::pattern));
    ASSERT_TRUE(r.ok()) << r.error().message;
    auto job = FrameJob::create(std::move(*r), {});
    ASSERT_TRUE(job.ok()) << job.error().message;
    auto result = run_frame_job(**job);
    ASSERT_TRUE(result.ok()) << result.error().message;
    for (const auto& path : job_settings(Source::pattern)) {
      if (path.rfind("params.", 0) == 0) continue;  // each pattern reads its own
      EXPECT_TRUE((*job)->request().read.count(path)) << path;
    }
  }
}

TEST(FrameJob, RenderUsesEverySettingItTakes) {
  auto renderer = shading::Renderer::create();
  if (!renderer) GTEST_SKIP() << "no GL renderer: " << renderer.error().message;
  Inputs in;
  json body = everything(in);
  body["width"] = 32, body["height"] = 18, body["samples"] = 1, body["encoder"] = "cpu";
  body["camera"] = {{"position", {0, 1, 4}}, {"target", {0, 0.5, 0}}, {"fov_y_deg", 50}};
  auto r = parse_request_json(body, cli_context(Source::render));
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto job = FrameJob::create(std::move(*r), {});
  ASSERT_TRUE(job.ok()) << job.error().message;
  auto result = run_frame_job(**job, renderer->get());
  ASSERT_TRUE(result.ok()) << result.error().message;
  expect_all_read((*job)->request(), Source::render);
  EXPECT_EQ(result->encoder, "cpu");
}

// RTR4 §8.2.2 meters the light: a render with a dominant light is exposed from it, one
// without from its histogram; an EXR is shown as authored.
TEST(FrameJob, ExposureRule) {
  auto req = [](Source s, const char* body) {
    auto r = parse_request_json(json::parse(body), cli_context(s));
    EXPECT_TRUE(r.ok()) << r.error().message;
    return *r;
  };
  EXPECT_EQ(exposure_mode(req(Source::render, "{}"), true), exposure::Mode::light);
  EXPECT_EQ(exposure_mode(req(Source::render, "{}"), false), exposure::Mode::histogram);
  EXPECT_EQ(exposure_mode(req(Source::encode, "{}"), false), exposure::Mode::manual);
  EXPECT_EQ(exposure_mode(req(Source::encode, R"({"exposure":{"ev100":10}})"), false), exposure::Mode::camera);
  EXPECT_EQ(exposure_mode(req(Source::render, R"({"exposure":{"mode":"log-average"}})"), true),
            exposure::Mode::log_average)
      << "a mode given is the mode used";
}

TEST(FrameJob, OutputsAreCheckedAgainstTheResolvedMode) {
  auto r = parse_request_json(json::parse(R"({"pattern":"window","display":{"mode":"scrgb"},"width":8,"height":8})"),
                              cli_context(Source::pattern));
  ASSERT_TRUE(r.ok());
  auto job = FrameJob::create(*r, {});
  ASSERT_TRUE(job.ok()) << job.error().message;
  for (Output o : (*job)->outputs()) EXPECT_NE(o, Output::png) << "scrgb's default dump has no PNG";
  EXPECT_FALSE((*job)->set_outputs({Output::png}).ok());
}

TEST(FrameJob, WritesAllOrNothing) {
  Inputs in;
  auto r = parse_request_json(json::parse(R"({"pattern":"pq-ramp","width":16,"height":8})"), cli_context(Source::pattern));
  ASSERT_TRUE(r.ok());
  auto job = FrameJob::create(std::move(*r), {});
  ASSERT_TRUE(job.ok());
  auto result = run_frame_job(**job);
  ASSERT_TRUE(result.ok());
  auto files = write_outputs(*result, in.dir / "ramp");
  ASSERT_TRUE(files.ok()) << files.error().message;
  for (const auto& [kind, path] : *files) EXPECT_TRUE(fs::exists(path)) << kind;
  const json sidecar = json::parse(testing::read_file(in.dir / "ramp.json"));
  EXPECT_EQ(sidecar["files"]["png"], "ramp.png");
  EXPECT_EQ(sidecar["settings"]["request"]["pattern"], "pq-ramp");
  // A directory that does not exist: nothing is written, the error names the file.
  auto bad = write_outputs(*result, in.dir / "missing" / "ramp");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, "io.write");
  EXPECT_FALSE(fs::exists(in.dir / "missing"));
}

}  // namespace
}  // namespace hdrd::job

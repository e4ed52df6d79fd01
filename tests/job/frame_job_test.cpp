// The frame job: every setting a request can carry is used (none is parsed and then
// ignored), the rules it decides once (exposure, encoder, outputs) and its all-or-nothing
// outputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "job/build.hpp"
#include "job/frame_job.hpp"
#include "shading/renderer.hpp"
#include "shading/scene_loader.hpp"
#include "tests/encode/io/png_util.hpp"
#include "tests/testing/standards.hpp"
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
    if (s.takes(source) && !s.sequence && s.reach == Reach::everywhere && s.type != Type::scene &&
        s.type != Type::base64)
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

// A render meters its picture (Unreal's histogram window), whatever light it has: light-based
// exposure only when its illuminance is given; an EXR is shown as authored.
TEST(FrameJob, ExposureRule) {
  auto req = [](Source s, const char* body) {
    auto r = parse_request_json(json::parse(body), cli_context(s));
    EXPECT_TRUE(r.ok()) << r.error().message;
    return *r;
  };
  EXPECT_EQ(exposure_mode(req(Source::render, "{}")), exposure::Mode::histogram);
  EXPECT_EQ(exposure_mode(req(Source::render, R"({"exposure":{"illuminance_lux":1000}})")), exposure::Mode::light);
  EXPECT_EQ(exposure_mode(req(Source::encode, "{}")), exposure::Mode::manual);
  EXPECT_EQ(exposure_mode(req(Source::encode, R"({"exposure":{"ev100":10}})")), exposure::Mode::camera);
  EXPECT_EQ(exposure_mode(req(Source::render, R"({"exposure":{"mode":"log-average"}})")), exposure::Mode::log_average)
      << "a mode given is the mode used";
}

// Issue 29 item 16: --encoder auto took the GPU pass on llvmpipe, where the CPU encoder is
// faster and the process smaller (docs/performance.md "Which encoder"). The choice by
// renderer kind, and the kind from real GL_RENDERER strings.
TEST(FrameJob, EncoderChoiceByRendererKind) {
  using shading::RendererKind;
  EXPECT_EQ(shading::renderer_kind("llvmpipe (LLVM 15.0.6, 256 bits)"), RendererKind::software);
  EXPECT_EQ(shading::renderer_kind("softpipe"), RendererKind::software);
  EXPECT_EQ(shading::renderer_kind("Mesa X11 / swrast"), RendererKind::software);
  EXPECT_EQ(shading::renderer_kind("Google SwiftShader"), RendererKind::software);
  EXPECT_EQ(shading::renderer_kind("NVIDIA H200/PCIe/SSE2"), RendererKind::hardware);
  EXPECT_EQ(shading::renderer_kind("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 15.0.6, DRM 3.54)"),
            RendererKind::hardware);
  EXPECT_EQ(shading::renderer_kind("Mesa Intel(R) UHD Graphics 620 (KBL GT2)"), RendererKind::hardware);
  const struct {
    const char* setting;
    RendererKind kind;
    bool exr;
    EncoderChoice want;
  } cases[] = {
      {"auto", RendererKind::software, false, EncoderChoice::cpu},
      {"auto", RendererKind::hardware, false, EncoderChoice::gpu},
      {"auto", RendererKind::hardware, true, EncoderChoice::cpu},
      {"auto", RendererKind::software, true, EncoderChoice::cpu},
      {"gpu", RendererKind::software, false, EncoderChoice::gpu},
      {"gpu", RendererKind::hardware, false, EncoderChoice::gpu},
      {"cpu", RendererKind::hardware, false, EncoderChoice::cpu},
      {"cpu", RendererKind::software, false, EncoderChoice::cpu},
  };
  for (const auto& c : cases)
    EXPECT_EQ(choose_encoder(c.setting, c.kind, c.exr), c.want)
        << c.setting << " " << shading::to_string(c.kind) << (c.exr ? " exr" : "");
}

// Issue 29 item 11: glTF emission has a unit, gltf_emissive_nits, a setting like any other
// (before, 1 cd/m2 fixed in the loader: emissive models looked unlit under the 100 lux rig).
// Its default is a white diffuser's luminance under 100 lux, E / pi (the light-based
// exposure's paper white), and the loader's own default is the same number.
TEST(FrameJob, GltfEmissiveNitsIsASettingReachingTheLoader) {
  const Setting* s = find_setting("gltf_emissive_nits");
  ASSERT_NE(s, nullptr);
  EXPECT_NEAR(s->default_value().get<double>(), 100 / M_PI, 1e-12);
  EXPECT_EQ(s->default_value().get<double>(), shading::kGltfEmissiveNits);
  EXPECT_EQ(shading::SceneLoadOptions{}.gltf_emissive_nits, shading::kGltfEmissiveNits);
  for (double nits : {1.0, 203.0}) {
    auto r = parse_request_json({{"scene", "material-grid"}, {"gltf_emissive_nits", nits}}, cli_context(Source::render));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(render_request(*r, {}).load.gltf_emissive_nits, nits);
  }
  auto d = parse_request_json({{"scene", "material-grid"}}, cli_context(Source::render));
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(render_request(*d, {}).load.gltf_emissive_nits, shading::kGltfEmissiveNits);
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

// The shareable stills come from the one frame: a gain-map JPEG's primary image is the SDR
// rendition, i.e. exactly what an sdr request for the same source makes (djpeg, an
// independent decoder, reads only the primary image of the MPF file).
TEST(FrameJob, GainMapPrimaryIsTheSdrRequestsFrame) {
  if (testing::run_command("command -v djpeg >/dev/null").exit_code != 0)
    GTEST_SKIP() << "djpeg not installed (Debian package libjpeg-turbo-progs)";
  Inputs in;
  auto make = [&](const char* body, const char* base) {
    auto r = parse_request_json(json::parse(body), cli_context(Source::encode));
    EXPECT_TRUE(r.ok()) << r.error().message;
    EncodeInput input;
    input.path = in.exr;
    auto job = FrameJob::create(std::move(*r), {}, input);
    EXPECT_TRUE(job.ok()) << job.error().message;
    auto result = run_frame_job(**job);
    EXPECT_TRUE(result.ok()) << result.error().message;
    auto files = write_outputs(*result, in.dir / base);
    EXPECT_TRUE(files.ok()) << files.error().message;
    return *files;
  };
  const auto hdr = make(R"({"display":{"mode":"hdr10"},"formats":["jpeg-gainmap","avif","jxl"]})", "hdr");
  const auto sdr = make(R"({"display":{"mode":"sdr"},"formats":["jpeg"]})", "sdr");
  EXPECT_EQ(hdr.at("jpeg-gainmap"), (in.dir / "hdr.jpg").string());
  const auto ppm = [&](const std::string& jpg) {
    const auto r = testing::run_command("djpeg -pnm '" + jpg + "'");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.out;
  };
  const std::string a = ppm(hdr.at("jpeg-gainmap")), b = ppm(sdr.at("jpeg"));
  EXPECT_GT(a.size(), 16u * 8 * 3);
  EXPECT_EQ(a, b) << "the gain-map JPEG's primary image is the SDR request's JPEG";
  const std::string avif = testing::read_file(hdr.at("avif")), jxl = testing::read_file(hdr.at("jxl"));
  EXPECT_EQ(avif.substr(4, 8), "ftypavif");
  EXPECT_TRUE(jxl.substr(0, 2) == "\xff\x0a" || jxl.substr(4, 4) == "JXL ") << "a JPEG XL codestream or container";
  const json sidecar = json::parse(testing::read_file(in.dir / "hdr.json"));
  EXPECT_EQ(sidecar["files"]["jpeg-gainmap"], "hdr.jpg");
  EXPECT_EQ(sidecar["files"]["avif"], "hdr.avif");
}

// Issue 29 item 7: one rule for a peak below paper white, the same in every output. The
// default paper white follows the peak (a warning says so) and every output is written,
// the gain-map JPEG included (it refused these settings); one asked for above the peak is
// kept, with a warning that it is clipped.
TEST(FrameJob, PaperWhiteFollowsALowerPeakInEveryOutput) {
  Inputs in;
  auto run = [&](const char* body) {
    auto r = parse_request_json(json::parse(body), cli_context(Source::encode));
    EXPECT_TRUE(r.ok()) << r.error().message;
    EncodeInput input;
    input.path = in.exr;
    auto job = FrameJob::create(std::move(*r), {}, input);
    EXPECT_TRUE(job.ok()) << job.error().message;
    return run_frame_job(**job);
  };
  auto has = [](const std::vector<std::string>& ws, const char* what) {
    for (const auto& w : ws)
      if (w.find(what) != std::string::npos) return true;
    return false;
  };
  for (const char* mode : {"hdr10", "hlg"}) {
    auto result = run(fmt::format(R"({{"display":{{"mode":"{}","peak_nits":150}},"formats":["png","raw","jpeg-gainmap","avif"]}})",
                                  mode)
                          .c_str());
    ASSERT_TRUE(result.ok()) << mode << ": " << result.error().message;
    EXPECT_EQ(result->frame.target.paper_white_nits, 150) << mode;
    EXPECT_EQ(result->frame.target.ui_white_nits, 150) << mode;
    EXPECT_EQ(result->files.size(), 4u) << mode;
    EXPECT_TRUE(has(result->warnings, "paper white follows the peak")) << mode;
  }
  auto asked = run(R"({"display":{"mode":"hdr10","peak_nits":150,"paper_white_nits":203},"formats":["raw"]})");
  ASSERT_TRUE(asked.ok()) << asked.error().message;
  EXPECT_EQ(asked->frame.target.paper_white_nits, 203);
  EXPECT_TRUE(has(asked->warnings, "clipped at the peak"));
  auto plain = run(R"({"display":{"mode":"hdr10","peak_nits":1000},"formats":["raw"]})");
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(has(plain->warnings, "paper white"));
}

// Issue 29 item 3: with the Hisense EDID (native white (0.2822, 0.2969), HLG only) the
// mastering display's white is D65, the white hdrd's frames are graded in (ST 2086), its
// primaries the panel's; forcing hdr10 on that HLG-only display warns.
TEST(FrameJob, MasteringWhiteIsD65AndForcedUnsignalledModesWarn) {
  HDRD_REQUIRE_FIXTURE(edid, "fixtures/edid/HEC002F_9A8CD18D45A1.bin");
  Inputs in;
  auto run = [&](const std::string& mode) {
    const std::string body = fmt::format(R"({{"display":{{{}"edid":"{}"}},"formats":["png"]}})",
                                         mode.empty() ? "" : "\"mode\":\"" + mode + "\",", edid.string());
    auto r = parse_request_json(json::parse(body), cli_context(Source::encode));
    EXPECT_TRUE(r.ok()) << r.error().message;
    EncodeInput input;
    input.path = in.exr;
    auto job = FrameJob::create(std::move(*r), {}, input);
    EXPECT_TRUE(job.ok()) << job.error().message;
    return run_frame_job(**job);
  };
  auto warned = [](const FrameResult& f) {
    for (const auto& w : f.warnings)
      if (w.find("does not signal SMPTE ST 2084 (PQ) (it signals HLG only)") != std::string::npos) return true;
    return false;
  };
  for (const char* mode : {"", "hdr10"}) {
    auto f = run(mode);
    ASSERT_TRUE(f.ok()) << f.error().message;
    const auto& m = f->frame.mastering;
    EXPECT_EQ(m.primaries.white.x, 0.3127) << mode;
    EXPECT_EQ(m.primaries.white.y, 0.3290) << mode;
    EXPECT_NEAR(m.primaries.red.x, 0.6396, 1e-3) << "the primaries stay the panel's";
    const json side = f->sidecar();
    EXPECT_EQ(side["mastering_display"]["primaries"]["white"], json::array({0.3127, 0.329}));
    EXPECT_EQ(warned(*f), std::string(mode) == "hdr10") << mode;
  }
}

TEST(FrameJob, StillsAreRefusedWhereTheModeHasNoForm) {
  auto create = [](const char* body) {
    auto r = parse_request_json(json::parse(body), cli_context(Source::pattern));
    EXPECT_TRUE(r.ok()) << r.error().message;
    return FrameJob::create(std::move(*r), {});
  };
  auto scrgb = create(R"({"pattern":"window","display":{"mode":"scrgb"},"formats":["avif"]})");
  ASSERT_FALSE(scrgb.ok());
  EXPECT_NE(scrgb.error().message.find("scrgb has no avif form"), std::string::npos) << scrgb.error().message;
  auto sdr_map = create(R"({"pattern":"window","display":{"mode":"sdr"},"formats":["jpeg-gainmap"]})");
  ASSERT_FALSE(sdr_map.ok());
  auto pattern_map = create(R"({"pattern":"window","display":{"mode":"hdr10"},"formats":["jpeg-gainmap"]})");
  ASSERT_FALSE(pattern_map.ok()) << "a pattern has no scene light for an SDR rendition";
  EXPECT_NE(pattern_map.error().message.find("not made by pattern requests"), std::string::npos)
      << pattern_map.error().message;
}

// The world's light through the request: the sky by any of its fields (or --sky), a map by
// file; the sidecar's render says what lit the frame; a file and a sky together are refused.
TEST(FrameJob, EnvironmentFromTheRequest) {
  auto renderer = shading::Renderer::create();
  if (!renderer) GTEST_SKIP() << "no GL renderer: " << renderer.error().message;
  Inputs in;
  Image env(16, 8);
  for (auto& v : env.rgba) v = 1.0f;
  ASSERT_TRUE(io::write_exr(in.dir / "env.exr", env, {}).ok());
  auto render = [&](json body) {
    body["width"] = 32, body["height"] = 18, body["samples"] = 1, body["formats"] = {"raw"};
    auto r = parse_request_json(body, cli_context(Source::render));
    EXPECT_TRUE(r.ok()) << r.error().message;
    auto job = FrameJob::create(std::move(*r), {});
    EXPECT_TRUE(job.ok()) << job.error().message;
    return run_frame_job(**job, renderer->get());
  };
  auto sky = render({{"environment", {{"sky", {{"sun_elevation_deg", 30}, {"turbidity", 3}}}}}});
  ASSERT_TRUE(sky.ok()) << sky.error().message;
  const std::string lit = sky->frame.settings["render"]["environment"];
  EXPECT_NE(lit.find("sky"), std::string::npos) << lit;
  auto map = render({{"environment", {{"file", (in.dir / "env.exr").string()}, {"scale", 500}}},
                     {"energy_compensation", false}});
  ASSERT_TRUE(map.ok()) << map.error().message;
  EXPECT_NE(map->frame.settings["render"]["environment"].get<std::string>().find("env.exr"), std::string::npos)
      << map->frame.settings["render"].dump();
  EXPECT_EQ(map->frame.settings["render"]["energy_compensation"], false);
  auto both = render({{"environment", {{"file", (in.dir / "env.exr").string()}, {"sky", {{"turbidity", 3}}}}}});
  EXPECT_FALSE(both.ok()) << "a map and a sky together";
  // The CLI's --sky is the same request.
  auto flags = cli_to_request_json({{"--sky", "30,0,3"}});
  ASSERT_TRUE(flags.ok()) << flags.error().message;
  EXPECT_EQ((*flags)["environment"]["sky"]["sun_elevation_deg"], 30);
  EXPECT_EQ((*flags)["environment"]["sky"]["turbidity"], 3);
}

// A render encoded on the GPU still gets its gain map: the scene light is read back for the
// SDR rendition.
TEST(FrameJob, RenderGainMap) {
  auto renderer = shading::Renderer::create();
  if (!renderer) GTEST_SKIP() << "no GL renderer: " << renderer.error().message;
  auto r = parse_request_json(json::parse(R"({"width":32,"height":18,"samples":1,"display":{"mode":"hlg"},
                                               "formats":["jpeg-gainmap"],"gainmap":{"channels":"luminance","scale":2}})"),
                              cli_context(Source::render));
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto job = FrameJob::create(std::move(*r), {});
  ASSERT_TRUE(job.ok()) << job.error().message;
  auto result = run_frame_job(**job, renderer->get());
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result->files.size(), 1u);
  const auto& bytes = result->files[0].bytes;
  ASSERT_GT(bytes.size(), 4u);
  EXPECT_EQ(bytes[0], 0xff);
  EXPECT_EQ(bytes[1], 0xd8);
  const std::string text(bytes.begin(), bytes.end());
  EXPECT_NE(text.find("hdrgm:Version"), std::string::npos) << "Ultra HDR XMP";
  EXPECT_NE(text.find("urn:iso:std:iso:ts:21496:-1"), std::string::npos) << "ISO 21496-1 metadata";
}

}  // namespace
}  // namespace hdrd::job

namespace hdrd::job {
namespace {

// Every built-in scene's default frame, with every default, looks right in HDR10: decoded
// here from its PQ codes with ST 2084's EOTF (maxRGB per pixel), the median lies between
// 2 and 300 cd/m2 and the 10th percentile above 0.1 cd/m2 (not black), and no more than 10 %
// of the pixels sit at the peak (not clipped). The hdr scene failed this before renders
// metered their picture: its room, 90 % of the frame, was below 0.01 cd/m2.
TEST(FrameJob, EveryBuiltInSceneDefaultFrameIsNeitherBlackNorClipped) {
  auto renderer = shading::Renderer::create();
  if (!renderer) GTEST_SKIP() << "no GL renderer: " << renderer.error().message;
  for (const std::string& scene : shading::builtin_scene_names()) {
    json body = {{"scene", scene}, {"width", 96}, {"height", 54}, {"display", {{"mode", "hdr10"}}}};
    auto r = parse_request_json(body, cli_context(Source::render));
    ASSERT_TRUE(r.ok()) << r.error().message;
    auto job = FrameJob::create(std::move(*r), {});
    ASSERT_TRUE(job.ok()) << job.error().message;
    auto result = run_frame_job(**job, renderer->get());
    ASSERT_TRUE(result.ok()) << result.error().message;
    const EncodedFrame& f = result->frame;
    std::vector<double> nits;
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        std::uint32_t w;
        std::memcpy(&w, f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4, 4);
        const unsigned m = std::max({w & 1023u, (w >> 10) & 1023u, (w >> 20) & 1023u});
        nits.push_back(testing::standard::pq_eotf(m / 1023.0));
      }
    std::sort(nits.begin(), nits.end());
    const auto at = [&](double p) { return nits[static_cast<std::size_t>(p / 100 * (nits.size() - 1))]; };
    EXPECT_GT(at(50), 2.0) << scene;
    EXPECT_LT(at(50), 300.0) << scene;
    EXPECT_GT(at(10), 0.1) << scene << ": the darkest tenth is black";
    EXPECT_LT(at(90), f.target.peak_nits * 0.98) << scene << ": a tenth of the frame at the peak";
  }
}

}  // namespace
}  // namespace hdrd::job

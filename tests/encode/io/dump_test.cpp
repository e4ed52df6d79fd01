// Raw dumps, JSON sidecars and write_dumps: bytes exactly as the frame holds them, every
// documented sidecar key, EXR dumps checked with OpenEXR's own reader, and all-or-nothing
// behaviour when any part fails.
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <set>

#include <sys/resource.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>

#include "encode/io/io.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::io {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::TempDir;

EncodedFrame frame_for(Mode mode, int w = 6, int h = 4) {
  EncodedFrame f;
  f.target = default_target(mode);
  f.width = w;
  f.height = h;
  int bpp = 4;
  if (mode == Mode::scrgb) {
    f.drm_fourcc = kDrmFormatAbgr16161616f;
    bpp = 8;
  } else if (mode == Mode::sdr || mode == Mode::sdr_bt1886) {
    f.drm_fourcc = kDrmFormatXrgb8888;
  } else {
    f.drm_fourcc = kDrmFormatXbgr2101010;
  }
  f.stride_bytes = static_cast<std::size_t>(w) * bpp + 16;
  f.data.resize(f.stride_bytes * h);
  for (std::size_t i = 0; i < f.data.size(); ++i) f.data[i] = static_cast<std::uint8_t>(i * 37 + 11);
  Image nits(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float* p = nits.px(x, y);
      p[0] = 10.0f * x + 0.5f;
      p[1] = 100.0f * y;
      p[2] = 203.0f;
      p[3] = 1.0f;
    }
  f.display_nits = nits;
  f.content_light = {123.2, 50.0};
  f.mastering = f.target.mastering();
  f.settings = {{"tonemap", "bt2390"}, {"tonemap_params", {{"knee", 0.5}}}, {"exposure_ev", 0.5}};
  return f;
}

std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

TEST(Raw, WritesTheDrmBufferExactly) {
  TempDir tmp;
  const EncodedFrame f = frame_for(Mode::hdr10);
  ASSERT_TRUE(write_raw(tmp / "f.raw", f).ok());
  const std::string bytes = testing::read_file(tmp / "f.raw");
  ASSERT_EQ(bytes.size(), f.stride_bytes * f.height);
  EXPECT_EQ(std::memcmp(bytes.data(), f.data.data(), bytes.size()), 0);
}

TEST(Sidecar, Hdr10Keys) {
  const EncodedFrame f = frame_for(Mode::hdr10);
  const json j = sidecar_json(f, {{"png", "x.png"}});
  EXPECT_EQ(j["format"], "hdrd-dump");
  EXPECT_EQ(j["format_version"], 1);
  EXPECT_EQ(j["mode"], "hdr10");
  EXPECT_EQ(j["fourcc"], "XB30");
  EXPECT_EQ(j["fourcc_code"], 0x30334258u);  // 'X' | 'B' << 8 | '3' << 16 | '0' << 24 (drm_fourcc.h)
  EXPECT_EQ(j["width"], 6);
  EXPECT_EQ(j["height"], 4);
  EXPECT_EQ(j["stride_bytes"], 6 * 4 + 16);
  EXPECT_EQ(j["bytes_per_pixel"], 4);
  EXPECT_EQ(j["bits"], 10);
  EXPECT_EQ(j["range"], "full");
  EXPECT_EQ(j["transfer"], "pq");
  EXPECT_EQ(j["container"]["name"], "rec2020");
  EXPECT_EQ(j["container"]["primaries"]["red"], json::array({0.708, 0.292}));
  EXPECT_EQ(j["container"]["primaries"]["white"], json::array({0.3127, 0.3290}));
  EXPECT_EQ(j["peak_nits"], 1000.0);
  EXPECT_EQ(j["black_nits"], 0.005);
  EXPECT_EQ(j["paper_white_nits"], 203.0);
  EXPECT_EQ(j["ui_white_nits"], 203.0);
  EXPECT_EQ(j["sdr_white_nits"], 203.0);
  EXPECT_EQ(j["mastering_display"]["primaries"]["green"], json::array({0.265, 0.690}));  // P3-D65 default
  EXPECT_EQ(j["mastering_display"]["max_nits"], 1000.0);
  EXPECT_EQ(j["mastering_display"]["min_nits"], 0.005);
  EXPECT_EQ(j["content_light_level"]["max_cll_nits"], 124);  // 123.2 rounded up (CTA-861.3 whole cd/m2)
  EXPECT_EQ(j["content_light_level"]["max_fall_nits"], 50);  // exact values are not bumped
  EXPECT_EQ(j["content_light_level"]["max_cll_nits_measured"], 123.2);
  EXPECT_EQ(j["files"]["png"], "x.png");
  EXPECT_EQ(j["settings"]["tonemap"], "bt2390");
  EXPECT_EQ(j["settings"]["tonemap_params"]["knee"], 0.5);
  EXPECT_FALSE(j.contains("hlg_system_gamma"));
}

TEST(Sidecar, OtherModes) {
  json j = sidecar_json(frame_for(Mode::scrgb), {});
  EXPECT_EQ(j["fourcc"], "AB4H");
  EXPECT_EQ(j["bytes_per_pixel"], 8);
  EXPECT_EQ(j["bits"], 16);
  EXPECT_EQ(j["transfer"], "linear");
  EXPECT_EQ(j["container"]["name"], "rec709");

  j = sidecar_json(frame_for(Mode::sdr), {});
  EXPECT_EQ(j["fourcc"], "XR24");
  EXPECT_EQ(j["bits"], 8);
  EXPECT_EQ(j["transfer"], "srgb");
  EXPECT_EQ(j["paper_white_nits"], 100.0);

  EncodedFrame n = frame_for(Mode::sdr_bt1886);
  n.target.range = Range::narrow;
  j = sidecar_json(n, {});
  EXPECT_EQ(j["transfer"], "bt1886");
  EXPECT_EQ(j["range"], "narrow");

  j = sidecar_json(frame_for(Mode::hlg), {});
  EXPECT_EQ(j["transfer"], "hlg");
  EXPECT_NEAR(j["hlg_system_gamma"].get<double>(), 1.2, 1e-12);  // BT.2100: 1.2 at Lw = 1000
}

TEST(DumpFormats, ParseAndDefaults) {
  EXPECT_EQ(parse_dump_format("png"), DumpFormat::png);
  EXPECT_EQ(parse_dump_format("exr"), DumpFormat::exr);
  EXPECT_EQ(parse_dump_format("raw"), DumpFormat::raw);
  EXPECT_FALSE(parse_dump_format("jpeg").has_value());
  EXPECT_EQ(default_formats(Mode::scrgb), (std::vector<DumpFormat>{DumpFormat::exr, DumpFormat::raw}));
  EXPECT_EQ(default_formats(Mode::hdr10).size(), 3u);
}

TEST(WriteDumps, Hdr10WritesEveryFileAndNothingElse) {
  TempDir tmp;
  const EncodedFrame f = frame_for(Mode::hdr10);
  const auto r = write_dumps(f, tmp / "desk", {DumpFormat::png, DumpFormat::exr, DumpFormat::raw});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"desk.png", "desk.exr", "desk.raw", "desk.json"}));
  EXPECT_EQ(r->files.at("sidecar"), (tmp / "desk.json").string());
  EXPECT_EQ(r->files.at("exr"), (tmp / "desk.exr").string());

  const json j = json::parse(testing::read_file(tmp / "desk.json"));
  EXPECT_EQ(j["files"], (json{{"png", "desk.png"}, {"exr", "desk.exr"}, {"raw", "desk.raw"}}));
  EXPECT_EQ(testing::read_file(tmp / "desk.raw"), std::string(f.data.begin(), f.data.end()));
  EXPECT_TRUE(read_png_info(tmp / "desk.png").ok());

  // EXR: display light in the container primaries, value x whiteLuminance = cd/m2.
  Imf::RgbaInputFile in((tmp / "desk.exr").c_str());
  ASSERT_TRUE(Imf::hasWhiteLuminance(in.header()));
  EXPECT_FLOAT_EQ(Imf::whiteLuminance(in.header()), 203.0f);
  EXPECT_FLOAT_EQ(Imf::chromaticities(in.header()).red.x, 0.708f);
  const auto* tm = in.header().findTypedAttribute<Imf::StringAttribute>("hdrd:settings.tonemap");
  ASSERT_NE(tm, nullptr);
  EXPECT_EQ(tm->value(), "bt2390");
  std::vector<Imf::Rgba> px(static_cast<std::size_t>(f.width) * f.height);
  in.setFrameBuffer(px.data(), 1, f.width);
  in.readPixels(0, f.height - 1);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const Imf::Rgba& p = px[static_cast<std::size_t>(y) * f.width + x];
      const float* n = f.display_nits->px(x, y);
      EXPECT_NEAR(p.r * 203.0, n[0], n[0] * 1e-3 + 1e-3);  // half: 11-bit significand
      EXPECT_NEAR(p.g * 203.0, n[1], n[1] * 1e-3 + 1e-3);
      EXPECT_NEAR(p.b * 203.0, n[2], n[2] * 1e-3);
    }
}

// Extra files (render's scene EXR, debug pictures) are written with the dump and listed.
TEST(WriteDumps, ExtraFilesAreWrittenAndListed) {
  TempDir tmp;
  const EncodedFrame f = frame_for(Mode::hdr10);
  const std::vector<ExtraFile> extra = {{"heatmap", ".heatmap.png", {1, 2, 3}}};
  const auto r = write_dumps(f, tmp / "d", {DumpFormat::raw}, extra);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"d.raw", "d.heatmap.png", "d.json"}));
  EXPECT_EQ(r->files.at("heatmap"), (tmp / "d.heatmap.png").string());
  EXPECT_EQ(testing::read_file(tmp / "d.heatmap.png"), std::string("\x01\x02\x03"));
  const json j = json::parse(testing::read_file(tmp / "d.json"));
  EXPECT_EQ(j["files"], (json{{"raw", "d.raw"}, {"heatmap", "d.heatmap.png"}}));
}

TEST(WriteDumps, ScrgbDefaultsAndEightyNitUnits) {
  TempDir tmp;
  const EncodedFrame f = frame_for(Mode::scrgb);
  const auto r = write_dumps(f, tmp / "s", {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"s.exr", "s.raw", "s.json"}));
  Imf::RgbaInputFile in((tmp / "s.exr").c_str());
  EXPECT_FLOAT_EQ(Imf::whiteLuminance(in.header()), 80.0f);
  EXPECT_FLOAT_EQ(Imf::chromaticities(in.header()).red.x, 0.64f);
  std::vector<Imf::Rgba> px(static_cast<std::size_t>(f.width) * f.height);
  in.setFrameBuffer(px.data(), 1, f.width);
  in.readPixels(0, f.height - 1);
  EXPECT_EQ(px[0].b.bits(), half(203.0f / 80.0f).bits());  // 203 cd/m2 = 2.5375 scRGB units, rounded to half
}

TEST(WriteDumps, FailuresLeaveNothingBehind) {
  TempDir tmp;
  EncodedFrame f = frame_for(Mode::scrgb);
  auto r = write_dumps(f, tmp / "a", {DumpFormat::raw, DumpFormat::png});  // scrgb has no PNG
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "png.unsupported");
  EXPECT_TRUE(listing(tmp.path()).empty());

  f = frame_for(Mode::hdr10);
  f.display_nits.reset();
  r = write_dumps(f, tmp / "b", {DumpFormat::png, DumpFormat::exr});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "dump.exr");
  EXPECT_TRUE(listing(tmp.path()).empty());

  f = frame_for(Mode::hdr10);
  r = write_dumps(f, tmp / "no-such-dir" / "c", {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "io.write");
  EXPECT_NE(r.error().message.find("no-such-dir"), std::string::npos) << r.error().message;
  std::ofstream(tmp / "plain-file") << "x";
  r = write_dumps(f, tmp / "plain-file" / "d", {});  // the "directory" is a file (we run as root: no chmod tricks)
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"plain-file"}));

  // The last rename fails (a non-empty directory holds the name): the files already
  // renamed are removed again and no temporary file is left.
  fs::create_directories(tmp / "e.raw" / "keep");
  r = write_dumps(f, tmp / "e", {DumpFormat::png, DumpFormat::exr, DumpFormat::raw});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "io.write");
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"plain-file", "e.raw"}));
  EXPECT_EQ(listing(tmp / "e.raw"), (std::set<std::string>{"keep"}));
}

// Failures injected after some files are already staged: the EXR cannot be produced while
// the raw file and the PNG are done; a write runs out of room (RLIMIT_FSIZE makes write(2)
// fail with EFBIG, as a full disk fails with ENOSPC) after the raw file was written.
TEST(WriteDumps, FailuresAfterOtherFilesWereStagedLeaveNothing) {
  TempDir tmp;
  EncodedFrame f = frame_for(Mode::hdr10, 64, 64);
  f.display_nits.reset();
  auto r = write_dumps(f, tmp / "a", {DumpFormat::raw, DumpFormat::png, DumpFormat::exr});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "dump.exr");
  EXPECT_TRUE(listing(tmp.path()).empty());

  f = frame_for(Mode::hdr10, 64, 64);  // raw 17 408 bytes; the PNG of noise codes ~25 000
  std::uint32_t lcg = 1;
  for (auto& b : f.data) b = static_cast<std::uint8_t>((lcg = lcg * 1664525u + 1013904223u) >> 24);
  const auto png = encode_png(f);
  ASSERT_GT(png->size(), 20000u);
  ASSERT_LT(f.data.size(), 20000u);
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = saved;
  small.rlim_cur = 20000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  r = write_dumps(f, tmp / "b", {DumpFormat::raw, DumpFormat::png});
  const auto single = write_png(tmp / "c.png", f);
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "io.write");
  EXPECT_NE(r.error().message.find("b.png"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("File too large"), std::string::npos) << r.error().message;
  ASSERT_FALSE(single.ok());
  EXPECT_TRUE(listing(tmp.path()).empty());

  const auto bad_level = write_dumps(f, tmp / "d", {}, {}, {.png = {.level = 12}, .write = {}});
  ASSERT_FALSE(bad_level.ok());
  EXPECT_EQ(bad_level.error().code, "png.level");
  EXPECT_TRUE(listing(tmp.path()).empty());
}

// durable: the same files (fsync changes when they reach the disk, not what they hold).
TEST(WriteDumps, DurableWritesTheSameFiles) {
  TempDir tmp;
  const EncodedFrame f = frame_for(Mode::hdr10);
  ASSERT_TRUE(write_dumps(f, tmp / "fast", {}).ok());
  const auto r = write_dumps(f, tmp / "safe", {}, {}, {.png = {}, .write = {.durable = true}});
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (const char* ext : {".png", ".exr", ".raw"})
    EXPECT_EQ(testing::read_file(tmp / (std::string("safe") + ext)), testing::read_file(tmp / (std::string("fast") + ext)))
        << ext;
  ASSERT_TRUE(atomic_write(tmp / "x.bin", f.data, {.durable = true}).ok());
  EXPECT_EQ(testing::read_file(tmp / "x.bin"), std::string(f.data.begin(), f.data.end()));
  EXPECT_EQ(listing(tmp.path()).size(), 9u);  // 2 x (png, exr, raw, json) + x.bin: no temporaries
}

TEST(AtomicWrite, ReplacesAndNeverTruncates) {
  TempDir tmp;
  const std::vector<std::uint8_t> a{1, 2, 3}, b{9, 8, 7, 6, 5};
  ASSERT_TRUE(atomic_write(tmp / "x.bin", a).ok());
  ASSERT_TRUE(atomic_write(tmp / "x.bin", b).ok());
  EXPECT_EQ(testing::read_file(tmp / "x.bin"), std::string("\x09\x08\x07\x06\x05", 5));
  fs::create_directories(tmp / "dir.bin" / "inside");
  const auto r = atomic_write(tmp / "dir.bin", a);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"x.bin", "dir.bin"}));
}

// The daemon removes the temporaries a killed writer left (daemon/jobs/dump_dir.cpp) by this
// predicate: the names create_temp makes, and nothing else.
TEST(AtomicWrite, TemporaryNamesAreRecognised) {
  EXPECT_TRUE(is_atomic_write_temporary(".frame.png.tmp-0123456789ab"));
  EXPECT_TRUE(is_atomic_write_temporary(".a.tmp-ffffffffffff"));
  for (const char* other : {"frame.png", ".frame.png", ".frame.png.tmp-0123456789a", ".frame.png.tmp-0123456789abc",
                            ".frame.png.tmp-0123456789AB", "frame.png.tmp-0123456789ab", ".tmp-0123456789ab", ""})
    EXPECT_FALSE(is_atomic_write_temporary(other)) << other;
}

// A sequence's staging directory (job/sequence.cpp): one a killed sequence left is swept with
// its staged files and the final-named files its journal names, and nothing else.
TEST(Staging, ASweepRemovesTheStagingAndWhatItsJournalNames) {
  TempDir tmp;
  const std::vector<std::uint8_t> bytes{1, 2, 3};
  auto staging = make_staging_dir(tmp / "shot");
  ASSERT_TRUE(staging.ok()) << staging.error().message;
  EXPECT_TRUE(is_staging_dir_name(staging->filename().string())) << *staging;
  ASSERT_TRUE(atomic_write(*staging / "shot.00000.png", bytes).ok());
  ASSERT_TRUE(atomic_write(*staging / "shot.00001.png", bytes).ok());
  ASSERT_TRUE(atomic_write(tmp / "other.png", bytes).ok());  // another job's
  // Killed during the final renames: frame 0 is in place, frame 1 still staged.
  ASSERT_TRUE(commit_staged(*staging, {"shot.00000.png", "shot.00001.png", "shot.json", "shot.mp4", "../escape", "a/b"},
                            {{*staging / "shot.00000.png", tmp / "shot.00000.png"}})
                  .ok());
  ASSERT_TRUE(fs::exists(tmp / "shot.00000.png"));
  EXPECT_EQ(sweep_staging(tmp.path()), 2u);  // shot.00000.png in place, shot.00001.png staged
  EXPECT_EQ(listing(tmp.path()), (std::set<std::string>{"other.png"}));
  for (const char* other : {"shot", ".shot", ".shot.staging-0123456789a", ".shot.tmp-0123456789ab", "shot.staging-0123456789ab"})
    EXPECT_FALSE(is_staging_dir_name(other)) << other;
}

}  // namespace
}  // namespace hdrd::io

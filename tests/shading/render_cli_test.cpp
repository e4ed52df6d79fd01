// `hdrd render` end to end: the dumps and the scene-referred EXR it writes, its JSON
// summary, and one-line errors for bad input with nothing left behind.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

using hdrd::testing::hdrd_binary;
using hdrd::testing::run_command;
using hdrd::testing::TempDir;

#define HDRD_REQUIRE_HDRD_BINARY()                                                                   \
  if (!std::filesystem::exists(hdrd_binary())) GTEST_SKIP() << "hdrd not built: " << hdrd_binary(); \
  if (!::hdrd::shading::testing::shared_renderer().renderer) GTEST_SKIP() << "no GL context"

TEST(RenderCli, WritesDumpsAndTheSceneReferredExr) {
  HDRD_REQUIRE_HDRD_BINARY();
  TempDir dir;
  const auto base = dir / "furnace";
  const auto r = run_command(hdrd_binary().string() + " render --scene furnace -o " + base.string() +
                             " --width 64 --height 36 --samples 1 --mode hdr10 --format png,raw,scene-exr --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["mode"], "hdr10");
  EXPECT_EQ(j["settings"]["render"]["scene"], "furnace");
  EXPECT_EQ(j["settings"]["render"]["width"], 64);
  EXPECT_FALSE(j["settings"]["render"]["gl_renderer"].get<std::string>().empty());
  for (const char* ext : {".png", ".raw", ".json", ".scene.exr"})
    EXPECT_TRUE(std::filesystem::exists(base.string() + ext)) << ext;
  EXPECT_NE(r.err.find("rendered furnace"), std::string::npos) << "progress on stderr: " << r.err;
  // The sidecar lists every file of the dump, the scene-referred EXR included.
  EXPECT_EQ(j["files"]["scene-exr"], base.string() + ".scene.exr");
  std::ifstream sidecar(base.string() + ".json");
  const auto side = nlohmann::json::parse(sidecar);
  EXPECT_EQ(side["files"]["scene-exr"], "furnace.scene.exr");
  EXPECT_EQ(side["files"]["png"], "furnace.png");
  EXPECT_EQ(side["files"]["raw"], "furnace.raw");
  // The scene EXR: float, absolute cd/m2 (whiteLuminance 1); the furnace is 1000 cd/m2.
  auto exr = io::read_exr(base.string() + ".scene.exr");
  ASSERT_TRUE(exr.ok()) << exr.error().message;
  ASSERT_TRUE(exr->white_luminance.has_value());
  EXPECT_EQ(*exr->white_luminance, 1.0);
  EXPECT_EQ(exr->image.width, 64);
  EXPECT_NEAR(exr->image.px(0, 0)[1], 1000.0f, 1e-3);  // the environment, behind everything
}

TEST(RenderCli, DefaultSceneAndCpuEncoder) {
  HDRD_REQUIRE_HDRD_BINARY();
  TempDir dir;
  const auto r = run_command(hdrd_binary().string() + " render -o " + (dir / "d").string() +
                             " --width 48 --height 27 --mode sdr --encoder cpu --format png --json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "-q: " << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["settings"]["render"]["scene"], "material-grid");
}

TEST(RenderCli, BadInputFailsWithOneLineAndNoFiles) {
  HDRD_REQUIRE_HDRD_BINARY();
  TempDir dir;
  const auto base = (dir / "x").string();
  const std::string cases[] = {
      "--scene no-such-scene", "--width 100000 --height 10", "--samples 0", "--camera 1,2",
      "--backend vulkan", "--encoder fpga", "--scene /nonexistent/model.glb"};
  for (const std::string& args : cases) {
    const auto r = run_command(hdrd_binary().string() + " render -o " + base + " " + args);
    EXPECT_NE(r.exit_code, 0) << args;
    const auto at = r.err.find("hdrd: error:");
    ASSERT_NE(at, std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(r.err.find('\n', at), r.err.size() - 1) << args << ": one line, last: " << r.err;
    EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << args << " left files behind";
  }
}

TEST(RenderCli, HelpHasExamples) {
  if (!std::filesystem::exists(hdrd_binary())) GTEST_SKIP() << "hdrd not built";
  const auto r = run_command(hdrd_binary().string() + " render --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("Examples:"), std::string::npos);
  EXPECT_NE(r.out.find("--backend"), std::string::npos);
}

}  // namespace
}  // namespace hdrd::shading

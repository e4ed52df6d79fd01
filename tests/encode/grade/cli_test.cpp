// hdrd lut bake / info / apply on the command line: JSON output, recorded peak, and
// one-line errors with the offending file and line.
#include <gtest/gtest.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <fstream>

#include "tests/testing/testing.hpp"

namespace {

using hdrd::testing::run_command;

class LutCli : public ::testing::Test {
 protected:
  void SetUp() override {
    hdrd_ = hdrd::testing::hdrd_binary().string();
    if (!std::filesystem::exists(hdrd_)) GTEST_SKIP() << "hdrd not built: " << hdrd_;
  }
  hdrd::testing::CommandResult run(const std::string& args) { return run_command(hdrd_ + " " + args); }
  std::string hdrd_;
  hdrd::testing::TempDir dir_;
};

TEST_F(LutCli, BakeRecordsPeakAndInfoReadsIt) {
  const auto cube = (dir_ / "b.cube").string();
  auto r = run(fmt::format("lut bake -q --curve reinhard --peak 600 --size 9 --shaper log2 -o {} --json", cube));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["peak_nits"], 600.0);
  EXPECT_EQ(j["shaper"], "log2");
  EXPECT_GT(j["bake_error"]["samples"].get<int>(), 20000);
  EXPECT_LT(j["bake_error"]["max_pq"].get<double>(), 0.05);
  r = run(fmt::format("lut info {} --json", cube));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["baked"]["peak_nits"], 600.0);
  EXPECT_EQ(info["baked"]["curve"], "reinhard");
  EXPECT_EQ(info["shaper"], "log2");
  EXPECT_EQ(info["lut3d"]["size"], 9);
}

TEST_F(LutCli, ErrorsAreOneLine) {
  const auto bad = (dir_ / "bad.cube").string();
  std::ofstream(bad) << "LUT_3D_SIZE 2\nDOMAIN_MIN 0 0\n";
  struct Case {
    std::string args, says;
  };
  const std::vector<Case> cases = {
      {"lut info " + bad, "bad.cube:2: DOMAIN_MIN takes three numbers"},
      {"lut export-identity --size 200 -o " + (dir_ / "x.png").string(), "--size 200 is outside 2..128"},
      {"lut export-identity --shaper gamma -o " + (dir_ / "x.png").string(), "shaper 'gamma': unknown shaper"},
      {"lut bake --curve nope -o " + (dir_ / "x.cube").string(), "unknown tone curve 'nope'"},
      {"lut import " + bad + " -o " + (dir_ / "y.cube").string(), "not a PNG file"},
      {"encode in.exr -o out --lut x.cube --grade scene --lut-shaper log2:-8", "log2 takes LO:HI stops around mid grey"},
  };
  for (const auto& c : cases) {
    const auto r = run(c.args);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find("hdrd: error: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << "\n" << r.err;
  }
}

}  // namespace

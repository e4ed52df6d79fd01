// The display-mode suite end to end: `hdrd selftest` for every mode of docs/display-modes.md.
#include <gtest/gtest.h>

#include <ostream>

#include <nlohmann/json.hpp>

#include "tests/testing/testing.hpp"

namespace {

struct ModeCase {
  const char* name;  // the test's name: hdr10_1000, ...
  const char* args;  // hdrd selftest arguments
};

// What gtest prints for the parameter (test listings, failures): the mode and its
// arguments, not the struct's bytes.
void PrintTo(const ModeCase& c, std::ostream* os) { *os << c.name << " (hdrd selftest " << c.args << ")"; }

class DisplayModes : public ::testing::TestWithParam<ModeCase> {};

TEST_P(DisplayModes, EveryCheckPasses) {
  const auto r = hdrd::testing::run_command(hdrd::testing::hdrd_binary().string() + " selftest " + GetParam().args +
                                            " --json -q");
  ASSERT_FALSE(r.out.empty()) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  int checks = 0;
  for (const auto& c : j["checks"]) {
    ++checks;
    EXPECT_FALSE(c["source"].get<std::string>().empty()) << c["name"];
    EXPECT_TRUE(c["passed"].get<bool>() || c["skipped"].get<bool>())
        << c["name"].get<std::string>() << ": " << c["detail"].get<std::string>() << " [" << c["source"] << "]";
  }
  EXPECT_GT(checks, 20);
  EXPECT_EQ(r.exit_code, j["passed"].get<bool>() ? 0 : 1);
  EXPECT_EQ(r.exit_code, 0);
}

INSTANTIATE_TEST_SUITE_P(Modes, DisplayModes,
                         ::testing::Values(ModeCase{"sdr_srgb", "--mode sdr-srgb"},
                                           ModeCase{"sdr_bt1886", "--mode sdr-bt1886"},
                                           ModeCase{"hdr10_150", "--mode hdr10 --peak 150"},
                                           ModeCase{"hdr10_426_856", "--mode hdr10 --peak 426.856"},
                                           ModeCase{"hdr10_400", "--mode hdr10 --peak 400"},
                                           ModeCase{"hdr10_600", "--mode hdr10 --peak 600"},
                                           ModeCase{"hdr10_1000", "--mode hdr10 --peak 1000"},
                                           ModeCase{"hdr10_4000", "--mode hdr10 --peak 4000"},
                                           ModeCase{"scrgb", "--mode scrgb"}, ModeCase{"hlg", "--mode hlg"}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(DisplayModesCli, UnknownModeIsAnError) {
  const auto r = hdrd::testing::run_command(hdrd::testing::hdrd_binary().string() + " selftest --mode hdr11");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("unknown mode"), std::string::npos) << r.err;
}

}  // namespace

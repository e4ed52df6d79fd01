// The built `hdrd edid`, `hdrd displays` and `hdrd present` as a user runs them: JSON keys
// the issue lists, values against manifest.json, one-line errors, the headless behaviour.
#include <gtest/gtest.h>

#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/drm_device.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

using nlohmann::json;
using hdrd::testing::run_command;

std::string hdrd() { return hdrd::testing::hdrd_binary().string(); }

int count_lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

TEST(HdrdEdidCli, JsonHasTheIssuesKeysForEveryFixture) {
  auto m = hdrd::testing::fixture("fixtures/edid/manifest.json");
  if (!m) GTEST_SKIP() << "shared fixture missing: ../shared/fixtures/edid";
  const json manifest = json::parse(hdrd::testing::read_file(*m));
  for (const json& e : manifest["edids"]) {
    const std::string file = e["file"].get<std::string>();
    SCOPED_TRACE(file);
    auto r = run_command(hdrd() + " edid --no-overrides --json " + (m->parent_path() / file).string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const json j = json::parse(r.out);
    for (const char* key : {"manufacturer", "product_code", "name", "chromaticity", "hdr_static_metadata",
                            "colorimetry", "warnings", "profile"})
      EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["manufacturer"], e["manufacturer"]);
    EXPECT_EQ(j["product_code"], e["product_code"]);
    EXPECT_EQ(j["name"], e["display_product_name"]);
    for (const char* c : {"red", "green", "blue", "white"})
      EXPECT_EQ(j["chromaticity"][c], e["chromaticity"]["exact_raw_div_1024"][c]) << c;
    EXPECT_EQ(j["hdr_static_metadata"].is_null(), !e["hdr_static_metadata_present"].get<bool>());
    if (!j["hdr_static_metadata"].is_null()) {
      const json& h = e["hdr_static_metadata"];
      EXPECT_EQ(j["hdr_static_metadata"]["max_luminance_cd_m2"].is_null(), h["desired_max_luminance_cd_m2"].is_null());
      if (!h["desired_max_luminance_cd_m2"].is_null()) {
        EXPECT_NEAR(j["hdr_static_metadata"]["max_luminance_cd_m2"].get<double>(),
                    h["formula_exact"]["max_cd_m2_formula"].get<double>(), 1e-9);
      }
    }
    const auto colorimetry = j["colorimetry"].get<std::vector<std::string>>();
    const bool bt2020 = e["colorimetry_data_block_present"].get<bool>() && e["colorimetry"]["BT2020RGB"].get<bool>();
    EXPECT_EQ(std::count(colorimetry.begin(), colorimetry.end(), "BT2020RGB"), bt2020 ? 1 : 0);
    EXPECT_TRUE(j["warnings"].is_array());
    EXPECT_TRUE(j["profile"]["mode"].is_string());
    EXPECT_TRUE(j["profile"]["peak_nits"].is_number());
  }
}

TEST(HdrdEdidCli, TextAndOverrideAndErrors) {
  auto bin = hdrd::testing::fixture("fixtures/edid/DELA0EA_29633DC619A6.bin");
  if (!bin) GTEST_SKIP() << "shared fixture missing";
  auto text = run_command(hdrd() + " edid --no-overrides " + bin->string());
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_EQ(text.out.rfind("Block 0, Base EDID:\n  EDID Structure Version & Revision: 1.3\n", 0), 0u);
  EXPECT_NE(text.out.find("    Desired content max luminance: 255 (12525.722 cd/m^2)\n"), std::string::npos);
  EXPECT_NE(text.out.find("peak 400.000 cd/m2"), std::string::npos);  // DisplayHDR 400 class, not 1000

  const auto override_file = hdrd::testing::source_dir() / "config/profiles/dell-u2718q.toml";
  auto over = run_command(hdrd() + " edid --no-overrides --json " + bin->string() + " --profile " + override_file.string());
  ASSERT_EQ(over.exit_code, 0) << over.err;
  EXPECT_EQ(json::parse(over.out)["profile"]["peak_nits"], 400);

  hdrd::testing::TempDir tmp;
  std::ofstream(tmp / "junk.bin") << std::string(300, 'x');
  auto bad = run_command(hdrd() + " edid " + (tmp / "junk.bin").string());
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_EQ(count_lines(bad.err), 1);
  EXPECT_NE(bad.err.find("hdrd: error: "), std::string::npos);
  EXPECT_NE(bad.err.find("not an EDID"), std::string::npos);
}

TEST(HdrdDisplaysCli, ListsWhatThisMachineHas) {
  auto r = run_command(hdrd() + " displays --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_EQ(j["devices"].get<std::vector<std::string>>(), drm_card_paths());
  if (drm_card_paths().empty()) {
    EXPECT_TRUE(j["connectors"].empty());
    auto text = run_command(hdrd() + " displays");
    EXPECT_EQ(text.exit_code, 0);
    EXPECT_EQ(text.out.rfind("No displays: no DRM devices", 0), 0u) << text.out;
  }
}

TEST(HdrdPresentCli, HeadlessSaysNoDisplayInOneLine) {
  if (!drm_card_paths().empty()) GTEST_SKIP() << "this machine has DRM devices; the headless path is not testable";
  hdrd::testing::TempDir tmp;
  std::ofstream(tmp / "f.json") << R"({"mode": "hdr10", "fourcc": "XB30", "width": 2, "height": 2})";
  std::ofstream(tmp / "f.raw", std::ios::binary) << std::string(16, '\0');
  auto r = run_command(hdrd() + " present " + (tmp / "f.json").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "hdrd: error: no display attached: this machine has no DRM devices (headless)\n");
  EXPECT_TRUE(r.out.empty());
  auto bad = run_command(hdrd() + " present " + (tmp / "f.json").string() + " --scrgb maybe");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_EQ(count_lines(bad.err), 1);
}

TEST(HdrdPresentCli, SequencesAreCheckedBeforeLookingForADisplay) {
  if (!drm_card_paths().empty()) GTEST_SKIP() << "this machine has DRM devices; the headless path is not testable";
  hdrd::testing::TempDir tmp;
  for (int i : {0, 1, 3}) {
    std::ofstream(tmp / fmt::format("w.{:05d}.json", i)) << R"({"mode": "hdr10", "fourcc": "XB30", "width": 2, "height": 2})";
    std::ofstream(tmp / fmt::format("w.{:05d}.raw", i), std::ios::binary) << std::string(16, '\0');
  }
  const std::string pattern = "'" + (tmp / "w.%05d.json").string() + "'";
  auto gap = run_command(hdrd() + " present " + pattern);
  EXPECT_EQ(gap.exit_code, 1);
  EXPECT_EQ(gap.err, "hdrd: error: " + (tmp / "w.%05d.json").string() + ": frame 2 is missing (frames 0..1 exist, then 3)\n");
  auto two = run_command(hdrd() + " present " + (tmp / "w.00000.json").string() + " " + (tmp / "w.00001.json").string() +
                         " --fps 24 --json");
  EXPECT_EQ(two.exit_code, 1);
  EXPECT_EQ(two.err, "hdrd: error: no display attached: this machine has no DRM devices (headless)\n");
  EXPECT_TRUE(two.out.empty());
  for (const char* bad : {" --pacing fast", " --buffers 4", " --fps -1"}) {
    auto r = run_command(hdrd() + " present " + tmp.path().string() + bad);
    EXPECT_EQ(r.exit_code, 1) << bad;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
  }
}

}  // namespace
}  // namespace hdrd::display

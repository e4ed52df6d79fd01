// Every real EDID in ../shared/fixtures/edid against the ground truth in manifest.json
// (itself from edid-decode, cross-checked byte by byte), and hdrd's edid-decode-style
// text against the stored edid-decode output. One test per EDID, driven by the manifest.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/edid.hpp"
#include "display/edid_json.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
  const std::string s = hdrd::testing::read_file(p);
  return {s.begin(), s.end()};
}

const json& manifest() {
  static const json m = [] {
    auto p = hdrd::testing::fixture("fixtures/edid/manifest.json");
    return p ? json::parse(hdrd::testing::read_file(*p)) : json();
  }();
  return m;
}

std::vector<std::string> manifest_files() {
  std::vector<std::string> files;
  if (manifest().is_object())
    for (const auto& e : manifest()["edids"]) files.push_back(e["file"].get<std::string>());
  if (files.empty()) files.push_back("missing");  // one test that skips with a message
  return files;
}

const json& entry(const std::string& file) {
  for (const auto& e : manifest()["edids"])
    if (e["file"] == file) return e;
  throw std::runtime_error("no manifest entry for " + file);
}

class EdidFixture : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "missing" || !manifest().is_object()) GTEST_SKIP() << "shared fixture missing: ../shared/fixtures/edid";
    auto path = hdrd::testing::fixture("fixtures/edid/" + GetParam());
    ASSERT_TRUE(path) << GetParam();
    bytes_ = read_bytes(*path);
    auto r = parse_edid(bytes_);
    ASSERT_TRUE(r.ok()) << r.error().message;
    info_ = std::move(r.value());
    m_ = &entry(GetParam());
  }
  std::vector<std::uint8_t> bytes_;
  EdidInfo info_;
  const json* m_ = nullptr;
};

std::string made_in_text(const EdidInfo& e) {
  if (e.model_year) return fmt::format("model year {}", e.manufacture_year);
  if (e.manufacture_week) return fmt::format("week {} of {}", e.manufacture_week, e.manufacture_year);
  return fmt::format("{}", e.manufacture_year);
}

// Values the manifest gives "to 3 decimals" (edid-decode's %.3f).
void expect_3_decimals(double actual, const json& expected, const std::string& what) {
  ASSERT_TRUE(expected.is_number()) << what;
  EXPECT_EQ(fmt::format("{:.3f}", actual), fmt::format("{:.3f}", expected.get<double>())) << what;
}

TEST_P(EdidFixture, IdentificationMatchesManifest) {
  const json& m = *m_;
  EXPECT_EQ(info_.size_bytes, m["size_bytes"].get<std::size_t>());
  EXPECT_EQ(fmt::format("{}.{}", info_.version, info_.revision), m["edid_version"].get<std::string>());
  EXPECT_EQ(info_.manufacturer, m["manufacturer"].get<std::string>());
  EXPECT_EQ(info_.product_code, m["product_code"].get<int>());
  EXPECT_EQ(fmt::format("0x{:04X}", info_.product_code), m["product_code_hex"].get<std::string>());
  EXPECT_EQ(info_.name, m["display_product_name"].get<std::string>());
  EXPECT_EQ(made_in_text(info_), m["made_in"].get<std::string>());
  EXPECT_EQ(info_.serial_number != 0, m["serial_number_field_nonzero"].get<bool>());
}

TEST_P(EdidFixture, ExtensionBlocksMatchManifest) {
  const json& m = *m_;
  std::vector<std::string> tags, names{"Base EDID"};
  for (const auto& e : info_.extensions) {
    tags.push_back(fmt::format("0x{:02x}", e.tag));
    names.push_back(e.name);
  }
  EXPECT_EQ(tags, m["extension_block_tags"].get<std::vector<std::string>>());
  EXPECT_EQ(names, m["blocks_edid_decode"].get<std::vector<std::string>>());
  std::vector<std::string> versions;
  for (const auto& s : info_.displayid) versions.push_back(s.version_string());
  EXPECT_EQ(versions, m.value("displayid_versions", json::array()).get<std::vector<std::string>>());
}

TEST_P(EdidFixture, ChromaticityMatchesManifest) {
  const json& c = (*m_)["chromaticity"];
  const std::pair<const char*, RawXy> coords[] = {{"red", info_.chromaticity.red},
                                                  {"green", info_.chromaticity.green},
                                                  {"blue", info_.chromaticity.blue},
                                                  {"white", info_.chromaticity.white}};
  for (const auto& [name, raw] : coords) {
    SCOPED_TRACE(name);
    EXPECT_EQ(raw.x, c["raw_10bit"][name][0].get<int>());
    EXPECT_EQ(raw.y, c["raw_10bit"][name][1].get<int>());
    EXPECT_DOUBLE_EQ(raw.value().x, c["exact_raw_div_1024"][name][0].get<double>());
    EXPECT_DOUBLE_EQ(raw.value().y, c["exact_raw_div_1024"][name][1].get<double>());
    // edid-decode truncates to 4 decimals (manifest chromaticity_formula).
    EXPECT_NEAR(std::floor(raw.x * 10000.0 / 1024.0) / 10000.0, c["edid_decode_printed"][name][0].get<double>(), 1e-9);
    EXPECT_NEAR(std::floor(raw.y * 10000.0 / 1024.0) / 10000.0, c["edid_decode_printed"][name][1].get<double>(), 1e-9);
  }
  // The JSON form is raw / 1024 as [x, y] (the contract).
  const json j = edid_to_json(info_);
  EXPECT_DOUBLE_EQ(j["chromaticity"]["red"][0].get<double>(), c["exact_raw_div_1024"]["red"][0].get<double>());
  EXPECT_DOUBLE_EQ(j["chromaticity"]["white"][1].get<double>(), c["exact_raw_div_1024"]["white"][1].get<double>());
}

void expect_optional_cv(const std::optional<std::uint8_t>& cv, const json& expected, const char* what) {
  if (expected.is_null()) {
    EXPECT_FALSE(cv.has_value()) << what;
  } else {
    ASSERT_TRUE(cv.has_value()) << what;
    EXPECT_EQ(int(*cv), expected.get<int>()) << what;
  }
}

void expect_optional_nits(const std::optional<double>& v, const json& printed, const json& exact, const char* what) {
  if (printed.is_null()) {
    EXPECT_FALSE(v.has_value()) << what;
    return;
  }
  ASSERT_TRUE(v.has_value()) << what;
  expect_3_decimals(*v, printed, what);
  EXPECT_NEAR(*v, exact.get<double>(), 1e-9 * std::max(1.0, std::abs(*v))) << what;
}

TEST_P(EdidFixture, HdrStaticMetadataMatchesManifest) {
  const json& m = *m_;
  ASSERT_EQ(info_.hdr_static_metadata.has_value(), m["hdr_static_metadata_present"].get<bool>());
  const json j = edid_to_json(info_);
  if (!info_.hdr_static_metadata) {
    EXPECT_TRUE(j["hdr_static_metadata"].is_null());
    return;
  }
  const auto& h = *info_.hdr_static_metadata;
  const json& e = m["hdr_static_metadata"];
  EXPECT_EQ(h.location, e["location"].get<std::string>());
  EXPECT_EQ(h.payload_length, e["block_payload_length"].get<int>());
  EXPECT_EQ(h.eotf_bits, e["eotf_byte"].get<int>());
  EXPECT_EQ(h.sdr(), e["eotfs"]["traditional_sdr"].get<bool>());
  EXPECT_EQ(h.hdr(), e["eotfs"]["traditional_hdr"].get<bool>());
  EXPECT_EQ(h.pq(), e["eotfs"]["st2084_pq"].get<bool>());
  EXPECT_EQ(h.hlg(), e["eotfs"]["hlg"].get<bool>());
  EXPECT_EQ(h.static_metadata_type1(), e["static_metadata_type1"].get<bool>());
  EXPECT_EQ(info_.hdr_static_metadata_blocks, e["n_hdr_static_blocks"].get<int>());
  expect_optional_cv(h.max_luminance_cv, e["desired_max_luminance_cv"], "max CV");
  expect_optional_cv(h.max_frame_avg_luminance_cv, e["desired_max_frame_avg_luminance_cv"], "max FALL CV");
  expect_optional_cv(h.min_luminance_cv, e["desired_min_luminance_cv"], "min CV");
  const json& exact = e["formula_exact"];
  expect_optional_nits(h.max_luminance_cd_m2(), e["desired_max_luminance_cd_m2"], exact["max_cd_m2_formula"], "max");
  expect_optional_nits(h.max_frame_avg_luminance_cd_m2(), e["desired_max_frame_avg_luminance_cd_m2"],
                       exact["maxfall_cd_m2_formula"], "max FALL");
  expect_optional_nits(h.min_luminance_cd_m2(), e["desired_min_luminance_cd_m2"], exact["min_cd_m2_formula"], "min");

  // The JSON contract: eotfs as names, luminance null when absent.
  std::vector<std::string> eotfs;
  if (e["eotfs"]["traditional_sdr"].get<bool>()) eotfs.push_back("sdr");
  if (e["eotfs"]["traditional_hdr"].get<bool>()) eotfs.push_back("hdr");
  if (e["eotfs"]["st2084_pq"].get<bool>()) eotfs.push_back("pq");
  if (e["eotfs"]["hlg"].get<bool>()) eotfs.push_back("hlg");
  EXPECT_EQ(j["hdr_static_metadata"]["eotfs"].get<std::vector<std::string>>(), eotfs);
  EXPECT_EQ(j["hdr_static_metadata"]["max_luminance_cd_m2"].is_null(), e["desired_max_luminance_cd_m2"].is_null());
  EXPECT_EQ(j["hdr_static_metadata"]["min_luminance_cd_m2"].is_null(), e["desired_min_luminance_cd_m2"].is_null());
}

TEST_P(EdidFixture, ColorimetryMatchesManifest) {
  const json& m = *m_;
  ASSERT_EQ(info_.colorimetry.has_value(), m["colorimetry_data_block_present"].get<bool>());
  const json j = edid_to_json(info_);
  if (!info_.colorimetry) {
    EXPECT_TRUE(j["colorimetry"].empty());
    return;
  }
  const auto& c = *info_.colorimetry;
  const json& e = m["colorimetry"];
  EXPECT_EQ(c.byte3, e["raw_bytes"][0].get<int>());
  EXPECT_EQ(c.byte4, e["raw_bytes"][1].get<int>());
  EXPECT_EQ(c.bt2020_rgb(), e["BT2020RGB"].get<bool>());
  EXPECT_EQ(c.bt2020_ycc(), e["BT2020YCC"].get<bool>());
  EXPECT_EQ(c.bt2020_cycc(), e["BT2020cYCC"].get<bool>());
  EXPECT_EQ(c.st2113_rgb(), e["DCI_P3_aka_ST2113RGB"].get<bool>());
  EXPECT_EQ(c.ictcp(), e["ICtCp"].get<bool>());
  auto names = c.names();
  auto expected = m["colorimetry_edid_decode"].get<std::vector<std::string>>();
  std::sort(names.begin(), names.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(names, expected);
  const auto listed = j["colorimetry"].get<std::vector<std::string>>();
  EXPECT_EQ(std::count(listed.begin(), listed.end(), "BT2020RGB"), e["BT2020RGB"].get<bool>() ? 1 : 0);
}

TEST_P(EdidFixture, VendorBlocksAndDisplayIdMatchManifest) {
  const json& m = *m_;
  EXPECT_EQ(info_.hdr10plus_vsvdb, m["hdr10plus_vsvdb"].get<bool>());
  const json& p = m["displayid_display_parameters"];
  ASSERT_EQ(info_.displayid_parameters.has_value(), !p.is_null());
  if (p.is_null()) return;
  const auto& d = *info_.displayid_parameters;
  EXPECT_NEAR(d.max_full_cd_m2(), p["native_max_full"].get<double>(), 5e-7);
  EXPECT_NEAR(d.max_10pct_cd_m2(), p["native_max_10pct"].get<double>(), 5e-7);
  EXPECT_NEAR(d.min_cd_m2(), p["native_min"].get<double>(), 5e-7);
  if (p.contains("colorspace_eotf_combinations")) {
    ASSERT_TRUE(info_.displayid_interface.has_value());
    const auto names = info_.displayid_interface->combination_names();
    EXPECT_EQ(fmt::format("{}", fmt::join(names, ", ")), p["colorspace_eotf_combinations"][0].get<std::string>());
  }
}

TEST_P(EdidFixture, WarnsAboutMissingExtensionBlocks) {
  // edid-decode's one failure that is about the blob's structure, which hdrd must see too.
  for (const auto& f : m_->value("edid_decode_failures", json::array())) {
    auto s = f.get<std::string>();
    if (s.find("extension block(s), but found") == std::string::npos) continue;
    if (s.back() == '.') s.pop_back();
    const bool found = std::any_of(info_.warnings.begin(), info_.warnings.end(), [&](const std::string& w) {
      return w.find(s.substr(s.find("EDID specified"))) != std::string::npos;
    });
    EXPECT_TRUE(found) << "missing warning: " << s;
  }
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::vector<std::string> edid_decode_lines(const std::string& file) {
  auto txt = hdrd::testing::fixture("fixtures/edid/edid-decode/" + file.substr(0, file.size() - 4) + ".txt");
  if (!txt) return {};
  auto all = lines_of(hdrd::testing::read_file(*txt));
  // Only the decode itself: the conformity report after "edid-decode SHA" is not ours.
  auto end = std::find_if(all.begin(), all.end(), [](const std::string& l) { return l.rfind("edid-decode SHA", 0) == 0; });
  return {all.begin(), end};
}

TEST_P(EdidFixture, TextIsASubsequenceOfEdidDecode) {
  const auto ref = edid_decode_lines(GetParam());
  ASSERT_FALSE(ref.empty());
  const auto ours = lines_of(format_edid_text(info_));
  std::size_t r = 0;
  for (const auto& line : ours) {
    const auto it = std::find(ref.begin() + static_cast<std::ptrdiff_t>(r), ref.end(), line);
    ASSERT_NE(it, ref.end()) << "line not in edid-decode output (in order): '" << line << "'\nafter edid-decode line "
                             << r << ": '" << (r ? ref[r - 1] : "") << "'";
    r = static_cast<std::size_t>(it - ref.begin()) + 1;
  }
}

TEST_P(EdidFixture, TextCoversEdidDecodesHdrLines) {
  // The reverse direction for the lines hdrd must not miss: every luminance, chromaticity,
  // colorimetry and native-luminance line edid-decode printed appears in our text.
  const auto ref = edid_decode_lines(GetParam());
  const std::string ours = format_edid_text(info_);
  const char* keys[] = {"Desired content", "Red  :", "Green:", "Blue :", "White:", "Native Maximum Luminance",
                        "Native Minimum Luminance", "Manufacturer:", "Model:", "Display Product Name:",
                        "Supported color space and EOTF", "HDR Static Metadata Data Block:", "Colorimetry Data Block:",
                        "SMPTE ST2084", "Hybrid Log-Gamma", "Static metadata type 1", "BT2020RGB"};
  for (const auto& line : ref)
    for (const char* k : keys) {
      if (line.find(k) != std::string::npos) {
        EXPECT_NE(ours.find(line + "\n"), std::string::npos) << "edid-decode line missing from ours: '" << line << "'";
      }
    }
}

// A DisplayID-only panel: its preferred timing is a DisplayID 2.0 type VII descriptor.
// edid-decode prints "DTD:  3120x2080  120.000000 Hz ... 900.864000 MHz ... preferred".
TEST(EdidDisplayIdTimings, PreferredTimingOfADisplayIdOnlyPanel) {
  auto path = hdrd::testing::fixture("fixtures/edid/EDO4179_82397317A590.bin");
  if (!path) GTEST_SKIP() << "shared fixture missing";
  auto e = parse_edid(read_bytes(*path));
  ASSERT_TRUE(e.ok());
  EXPECT_TRUE(e->detailed_timings.empty());
  ASSERT_EQ(e->displayid_timings.size(), 2u);
  const DetailedTiming* t = e->preferred_timing();
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->h_active, 3120);
  EXPECT_EQ(t->v_active, 2080);
  EXPECT_EQ(t->pixel_clock_khz, 900864u);
  EXPECT_EQ(t->h_front, 212);
  EXPECT_EQ(t->v_front, 122);
  EXPECT_NEAR(t->refresh_hz(), 120.0, 1e-9);
  EXPECT_NEAR(e->displayid_timings[1].refresh_hz(), 60.0, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Fixtures, EdidFixture, ::testing::ValuesIn(manifest_files()),
                         [](const ::testing::TestParamInfo<std::string>& i) {
                           std::string n = i.param.substr(0, i.param.find('.'));
                           std::replace_if(n.begin(), n.end(), [](char c) { return !std::isalnum(c); }, '_');
                           return n;
                         });

}  // namespace
}  // namespace hdrd::display

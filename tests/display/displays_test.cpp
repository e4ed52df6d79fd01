// Connector enumeration through the fake device (EDID blob -> profile, HDR properties),
// the auto-profile choice, the real libdrm path on whatever machine runs the tests, and
// reading a dump back for `hdrd present`.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

#include "display/displays.hpp"
#include "display/drm_device.hpp"
#include "display/dump_reader.hpp"
#include "encode/io/io.hpp"
#include "tests/display/fake_kms.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

using namespace hdrd::display::testing;

std::vector<std::uint8_t> fixture_bytes(const std::string& name) {
  auto p = hdrd::testing::fixture("fixtures/edid/" + name);
  if (!p) return {};
  const std::string s = hdrd::testing::read_file(*p);
  return {s.begin(), s.end()};
}

TEST(Displays, ConnectorReportCarriesEdidProfileAndHdrProperties) {
  auto edid = fixture_bytes("APPAE22_7A77CDD2C80F.bin");  // Pro Display XDR: HDR10, 1600 cd/m2
  if (edid.empty()) GTEST_SKIP() << "shared fixture missing: ../shared/fixtures/edid";
  FakeKmsDevice dev;
  dev.edid = edid;
  auto r = describe_connectors(dev);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->size(), 2u);
  const ConnectorReport& hdmi = (*r)[0];
  EXPECT_EQ(hdmi.connector.name, "HDMI-A-1");
  EXPECT_TRUE(hdmi.connected());
  ASSERT_TRUE(hdmi.edid);
  EXPECT_EQ(hdmi.edid->name, "ProDisplayXDR");
  ASSERT_TRUE(hdmi.profile);
  EXPECT_EQ(hdmi.profile->mode, Mode::hdr10);
  EXPECT_TRUE(hdmi.has_hdr_output_metadata);
  EXPECT_EQ(hdmi.max_bpc_range, std::make_pair(std::uint64_t{8}, std::uint64_t{12}));
  EXPECT_NE(std::find(hdmi.colorspaces.begin(), hdmi.colorspaces.end(), "BT2020_RGB"), hdmi.colorspaces.end());
  EXPECT_TRUE(hdmi.hdr_capable());
  EXPECT_FALSE((*r)[1].connected());
  EXPECT_FALSE((*r)[1].edid_error);  // a disconnected connector owes no EDID
  const auto j = to_json(hdmi);
  EXPECT_EQ(j["profile"]["mode"], "hdr10");
  EXPECT_EQ(j["properties"]["HDR_OUTPUT_METADATA"], true);
  EXPECT_EQ(j["edid"]["manufacturer"], "APP");
}

TEST(Displays, AutoProfilePrefersHdrCapableThenAnyConnected) {
  auto hdr = fixture_bytes("APPAE22_7A77CDD2C80F.bin");
  auto sdr = fixture_bytes("LEN61ED_1C6D9071F99B.bin");
  if (hdr.empty()) GTEST_SKIP() << "shared fixture missing";
  FakeKmsDevice sdr_dev, hdr_dev, no_props(/*hdr_properties=*/false);
  sdr_dev.edid = sdr;
  hdr_dev.edid = hdr;
  no_props.edid = hdr;
  DisplaysReport report;
  for (KmsDevice* d : std::initializer_list<KmsDevice*>{&sdr_dev, &no_props, &hdr_dev}) {
    auto conns = describe_connectors(*d);
    ASSERT_TRUE(conns.ok());
    for (auto& c : *conns) report.connectors.push_back(std::move(c));
  }
  auto p = choose_auto_profile(report);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->name, "ProDisplayXDR");  // the third connector: the first that can take HDR
  report.connectors.pop_back();
  report.connectors.pop_back();
  p = choose_auto_profile(report);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->mode, Mode::sdr);        // no HDR-capable output: the SDR monitor's profile
  EXPECT_FALSE(choose_auto_profile(DisplaysReport{}).has_value());
}

TEST(Displays, RealLibdrmEnumerationOnThisMachine) {
  // Whatever this machine has: headless CI has no DRM devices (drmGetDevices2 < 0).
  const auto paths = drm_card_paths();
  const DisplaysReport report = enumerate_displays();
  EXPECT_EQ(report.devices, paths);
  if (paths.empty()) {
    EXPECT_TRUE(report.connectors.empty());
    EXPECT_NE(report.note.find("no DRM devices"), std::string::npos);
    auto p = auto_profile();
    ASSERT_TRUE(p.ok()) << p.error().message;
    EXPECT_FALSE(p->has_value());
    auto named = select_profile("HDMI-A-1", "");
    ASSERT_FALSE(named.ok());
    EXPECT_EQ(named.error().message, "no display attached: no DRM devices, so no connector HDMI-A-1");
    const auto j = to_json(report);
    EXPECT_TRUE(j["connectors"].empty());
    EXPECT_TRUE(j["note"].is_string());
  } else {
    for (const auto& c : report.connectors) EXPECT_FALSE(c.connector.name.empty());
  }
}

TEST(Displays, SelectProfileFromAnEdidFileAndAnOverride) {
  auto path = hdrd::testing::fixture("fixtures/edid/DELA0EA_29633DC619A6.bin");
  if (!path) GTEST_SKIP() << "shared fixture missing";
  auto p = select_profile("", path->string(),
                          (hdrd::testing::source_dir() / "config/profiles/dell-u2718q.toml").string());
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_TRUE(p->has_value());
  EXPECT_EQ((*p)->peak_nits, 400);  // the override fixes the bogus 12526 cd/m2 claim
  auto none = select_profile("", "");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  auto bad = select_profile("", "/nonexistent.bin");
  EXPECT_FALSE(bad.ok());
}

EncodedFrame small_hdr10() {
  EncodedFrame f;
  f.target = default_target(Mode::hdr10);
  f.target.peak_nits = 600;
  f.width = 3;
  f.height = 2;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = 12;
  f.data.resize(24);
  for (std::size_t i = 0; i < f.data.size(); ++i) f.data[i] = static_cast<std::uint8_t>(i * 9);
  for (std::size_t i = 3; i < f.data.size(); i += 4) f.data[i] &= 0x3f;
  f.mastering = f.target.mastering();
  f.content_light = {512.25, 100.5};
  return f;
}

TEST(DumpReader, ReadsWhatTheIoModuleWrites) {
  hdrd::testing::TempDir tmp;
  const EncodedFrame f = small_hdr10();
  auto written = io::write_dumps(f, tmp / "frame", {io::DumpFormat::raw});
  ASSERT_TRUE(written.ok()) << written.error().message;
  auto back = read_dump(tmp / "frame.json");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->target.mode, Mode::hdr10);
  EXPECT_EQ(back->width, 3);
  EXPECT_EQ(back->height, 2);
  EXPECT_EQ(back->drm_fourcc, kDrmFormatXbgr2101010);
  EXPECT_EQ(back->data, f.data);
  EXPECT_EQ(back->target.peak_nits, 600);
  EXPECT_EQ(back->mastering.max_nits, 600);
  EXPECT_DOUBLE_EQ(back->content_light.max_cll_nits, 512.25);  // the measured value, not the rounded one
}

void write_text(const std::filesystem::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

TEST(DumpReader, MinimalSidecarAndClearErrors) {
  hdrd::testing::TempDir tmp;
  write_text(tmp / "m.json", R"({"mode": "sdr", "fourcc": "XR24", "width": 2, "height": 1})");
  write_text(tmp / "m.raw", std::string(8, '\x10'));
  auto f = read_dump(tmp / "m.json");
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->stride_bytes, 8u);
  EXPECT_EQ(f->target.peak_nits, 100);  // the mode's default

  write_text(tmp / "short.json", R"({"mode": "sdr", "fourcc": "XR24", "width": 4, "height": 1, "files": {"raw": "m.raw"}})");
  auto s = read_dump(tmp / "short.json");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("m.raw is 8 bytes; the sidecar's 4x1 at stride 16 needs 16"), std::string::npos);

  write_text(tmp / "nomode.json", R"({"fourcc": "XR24", "width": 2, "height": 1})");
  EXPECT_EQ(read_dump(tmp / "nomode.json").error().field, "mode");
  write_text(tmp / "bad.json", "not json");
  EXPECT_NE(read_dump(tmp / "bad.json").error().message.find("not a JSON object"), std::string::npos);
  write_text(tmp / "huge.json", R"({"mode": "sdr", "fourcc": "XR24", "width": 100000, "height": 1})");
  EXPECT_EQ(read_dump(tmp / "huge.json").error().field, "width");
  write_text(tmp / "fmt.json", R"({"mode": "hdr10", "fourcc": "XR24", "width": 2, "height": 1, "files": {"raw": "m.raw"}})");
  EXPECT_EQ(read_dump(tmp / "fmt.json").error().message, "hdr10 frames are XB30, not XR24");
}

}  // namespace
}  // namespace hdrd::display

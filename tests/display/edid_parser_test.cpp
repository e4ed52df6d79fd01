// EDID parser on synthetic blobs built byte by byte from the standards (E-EDID 1.4,
// CTA-861-G, DisplayID 2.0): field placement, optional bytes, and every malformation
// that must become a warning instead of a crash or a rejected EDID.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "display/edid.hpp"
#include "display/edid_json.hpp"
#include "tests/display/edid_builder.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

using namespace hdrd::display::testing;

bool has_warning(const EdidInfo& info, const std::string& needle) {
  return std::any_of(info.warnings.begin(), info.warnings.end(),
                     [&](const std::string& w) { return w.find(needle) != std::string::npos; });
}

EdidInfo parse_ok(const std::vector<std::uint8_t>& bytes) {
  auto r = parse_edid(bytes);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r.value()) : EdidInfo{};
}

TEST(EdidParser, RejectsShortBlobsAndBadHeaders) {
  EXPECT_EQ(parse_edid({}).error().code, "edid.too_short");
  auto b = assemble({base_block(0)});
  EXPECT_EQ(parse_edid(std::span(b).first(127)).error().code, "edid.too_short");
  b[3] = 0x00;
  const auto r = parse_edid(b);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "edid.bad_header");
  EXPECT_NE(r.error().message.find("00 FF FF FF FF FF FF 00"), std::string::npos);
}

TEST(EdidParser, BaseBlockFieldsAtTheirOffsets) {
  const auto e = parse_ok(assemble({base_block(0)}));
  EXPECT_EQ(e.manufacturer, "ABC");
  EXPECT_EQ(e.product_code, 0x1234);
  EXPECT_EQ(e.serial_number, 0x01020304u);
  EXPECT_EQ(e.manufacture_week, 10);
  EXPECT_EQ(e.manufacture_year, 2020);
  EXPECT_EQ(e.version, 1);
  EXPECT_EQ(e.revision, 4);
  EXPECT_TRUE(e.digital);
  EXPECT_EQ(e.bits_per_color, 10);
  EXPECT_EQ(e.interface, "DisplayPort");
  EXPECT_EQ(e.width_cm, 60);
  ASSERT_TRUE(e.gamma);
  EXPECT_DOUBLE_EQ(*e.gamma, 2.2);
  EXPECT_EQ(e.name, "Test Panel");
  ASSERT_NE(e.preferred_timing(), nullptr);
  EXPECT_EQ(e.preferred_timing()->h_active, 1920);
  EXPECT_EQ(e.preferred_timing()->v_active, 1080);
  EXPECT_EQ(e.preferred_timing()->pixel_clock_khz, 148500u);
  EXPECT_NEAR(e.preferred_timing()->refresh_hz(), 60.0, 1e-9);  // 148.5 MHz / (2200 x 1125)
  EXPECT_TRUE(e.warnings.empty()) << e.warnings.front();
}

TEST(EdidParser, ChromaticityLowBitsComeFromBytes0x19And0x1A) {
  // Eight distinct codes whose low 2 bits differ, so a swapped bit pair shows up.
  const std::uint16_t codes[8] = {655, 338, 306, 613, 153, 63, 320, 337};
  auto b = base_block(0);
  set_chromaticity(b, codes);
  const auto e = parse_ok(assemble({b}));
  const RawXy got[4] = {e.chromaticity.red, e.chromaticity.green, e.chromaticity.blue, e.chromaticity.white};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(got[i].x, codes[2 * i]) << i;
    EXPECT_EQ(got[i].y, codes[2 * i + 1]) << i;
  }
  EXPECT_DOUBLE_EQ(e.chromaticity.primaries().red.x, 655 / 1024.0);
}

TEST(EdidParser, ChecksumAndExtensionCountProblemsAreWarnings) {
  auto bytes = assemble({base_block(2), cta_block({})});
  bytes[20] ^= 0x01;  // breaks the base checksum
  const auto e = parse_ok(bytes);
  EXPECT_FALSE(e.base_checksum_ok);
  EXPECT_TRUE(has_warning(e, "checksum mismatch"));
  EXPECT_TRUE(has_warning(e, "EDID specified 2 extension block(s), but found 1 extension block(s)"));
  EXPECT_EQ(e.extensions.size(), 1u);
}

TEST(EdidParser, ExtraBlocksBeyondTheDeclaredCountAreIgnored) {
  const auto e = parse_ok(assemble({base_block(0), cta_block({})}));
  EXPECT_TRUE(e.extensions.empty());
  EXPECT_TRUE(has_warning(e, "ignored"));
}

TEST(EdidParser, HdrStaticMetadataOptionalLuminanceBytes) {
  // CTA-861-G §7.5.13: length 3 = no luminance, 4 = max, 5 = + frame-average, 6 = + min.
  for (int n = 0; n <= 3; ++n) {
    Block payload{0x05, 0x01, 96, 64, 255};
    payload.resize(2 + n);
    const auto e = parse_ok(assemble({base_block(1), cta_block({cta_extended(0x06, payload)})}));
    ASSERT_TRUE(e.hdr_static_metadata) << n;
    const auto& h = *e.hdr_static_metadata;
    EXPECT_EQ(h.payload_length, 3 + n);
    EXPECT_TRUE(h.sdr());
    EXPECT_TRUE(h.pq());
    EXPECT_FALSE(h.hlg());
    EXPECT_EQ(h.max_luminance_cv.has_value(), n >= 1);
    EXPECT_EQ(h.max_frame_avg_luminance_cv.has_value(), n >= 2);
    EXPECT_EQ(h.min_luminance_cv.has_value(), n >= 3);
    if (n >= 1) {
      EXPECT_DOUBLE_EQ(*h.max_luminance_cd_m2(), 400.0);  // 50 * 2^(96/32)
    }
    if (n >= 2) {
      EXPECT_DOUBLE_EQ(*h.max_frame_avg_luminance_cd_m2(), 200.0);  // 50 * 2^2
    }
    if (n >= 3) {
      EXPECT_DOUBLE_EQ(*h.min_luminance_cd_m2(), 4.0);  // 400 * 1^2 / 100
    }
    EXPECT_EQ(h.location, "CTA-861 extension (block 1)");
  }
}

TEST(EdidParser, LuminanceFormulasAgainstHandValues) {
  EXPECT_DOUBLE_EQ(cta_luminance_cd_m2(0), 50.0);
  EXPECT_DOUBLE_EQ(cta_luminance_cd_m2(32), 100.0);
  EXPECT_DOUBLE_EQ(cta_luminance_cd_m2(160), 1600.0);  // 50 * 2^5
  EXPECT_NEAR(cta_luminance_cd_m2(255), 12525.722395, 1e-6);  // edid-decode: 12525.722
  // min = max * (CV/255)^2 / 100: CV 51 of a 1000-ish max is 1/25 of 1 %.
  EXPECT_DOUBLE_EQ(cta_min_luminance_cd_m2(51, 160), 1600.0 * 0.04 / 100.0);
  EXPECT_DOUBLE_EQ(cta_min_luminance_cd_m2(0, 160), 0.0);
}

TEST(EdidParser, TruncatedHdrAndColorimetryBlocksWarn) {
  const auto e = parse_ok(assemble({base_block(1), cta_block({cta_extended(0x06, {0x05}),
                                                                cta_extended(0x05, {0x80})})}));
  EXPECT_FALSE(e.hdr_static_metadata);
  EXPECT_FALSE(e.colorimetry);
  EXPECT_TRUE(has_warning(e, "HDR Static Metadata Data Block: length 2 is too short"));
  EXPECT_TRUE(has_warning(e, "Colorimetry Data Block: length 2 is too short"));
}

TEST(EdidParser, DataBlockOverrunningTheCollectionStopsWithAWarning) {
  auto cta = cta_block({cta_extended(0x05, {0x80, 0x00})});
  cta[2] = 6;  // the DTD offset cuts the 4-byte colorimetry block in half
  const auto e = parse_ok(assemble({base_block(1), cta}));
  EXPECT_FALSE(e.colorimetry);
  EXPECT_TRUE(has_warning(e, "overruns the data block collection"));
}

TEST(EdidParser, BadDtdOffsetIsClampedAndReported) {
  auto cta = cta_block({});
  cta[2] = 2;
  const auto e = parse_ok(assemble({base_block(1), cta}));
  EXPECT_TRUE(has_warning(e, "detailed timing offset 2 is outside 4..127"));
}

TEST(EdidParser, ColorimetryBitsFollowCta861H) {
  const auto e = parse_ok(assemble({base_block(1), cta_block({cta_extended(0x05, {0xc0, 0xc0})})}));
  ASSERT_TRUE(e.colorimetry);
  EXPECT_TRUE(e.colorimetry->bt2020_rgb());
  EXPECT_TRUE(e.colorimetry->bt2020_ycc());
  EXPECT_TRUE(e.colorimetry->st2113_rgb());  // byte 4 bit 7 (DCI-P3 in CTA-861-G)
  EXPECT_TRUE(e.colorimetry->ictcp());       // byte 4 bit 6
  EXPECT_EQ(colorimetry_names(*e.colorimetry),
            (std::vector<std::string>{"BT2020YCC", "BT2020RGB", "ICtCp", "ST2113RGB"}));
}

TEST(EdidParser, Hdr10PlusAndDolbyVendorVideoBlocks) {
  // OUIs are stored least significant byte first: 90-84-8B as 8B 84 90.
  const auto e = parse_ok(assemble({base_block(1), cta_block({cta_extended(0x01, {0x8b, 0x84, 0x90, 0x01}),
                                                                cta_extended(0x01, {0x46, 0xd0, 0x00, 0x00})})}));
  EXPECT_TRUE(e.hdr10plus_vsvdb);
  EXPECT_TRUE(e.dolby_vision_vsvdb);
  EXPECT_EQ(e.cta.at(0).data_blocks.at(0).name, "Vendor-Specific Video Data Block (HDR10+), OUI 90-84-8B");
}

TEST(EdidParser, HfEeodbOverridesTheExtensionCount) {
  // Byte 0x7E says 1, the HDMI Forum override in block 1 says 2: both blocks are read.
  const auto e = parse_ok(assemble({base_block(1), cta_block({cta_extended(0x78, {0x02})}),
                                    cta_block({cta_extended(0x05, {0x80, 0x00})})}));
  EXPECT_EQ(e.extension_count, 2);
  EXPECT_EQ(e.extensions.size(), 2u);
  EXPECT_TRUE(e.colorimetry);
}

Block displayid_parameters(bool cie1976, std::uint16_t max_full, std::uint16_t max_10, std::uint16_t min) {
  Block p(29, 0);
  p[0] = 0x03; p[1] = 0x0c;  // 307.5 mm
  p[4] = 0x30; p[5] = 0x0c;  // 3120 px
  p[8] = cie1976 ? 0x40 : 0x00;
  // white point only (primaries left 0): 12-bit codes packed x lo8, x hi4 | y lo4 << 4, y hi8
  auto pack = [&](int i, std::uint16_t x, std::uint16_t y) {
    p[9 + 3 * i] = x & 0xff;
    p[10 + 3 * i] = static_cast<std::uint8_t>(((x >> 8) & 0x0f) | ((y & 0x0f) << 4));
    p[11 + 3 * i] = static_cast<std::uint8_t>(y >> 4);
  };
  pack(3, cie1976 ? 810 : 1281, cie1976 ? 1918 : 1348);
  p[21] = max_full & 0xff; p[22] = max_full >> 8;
  p[23] = max_10 & 0xff; p[24] = max_10 >> 8;
  p[25] = min & 0xff; p[26] = min >> 8;
  p[27] = 0x23;
  p[28] = 120;
  Block b{0x21, 0x00, 29};
  b.insert(b.end(), p.begin(), p.end());
  return b;
}

TEST(EdidParser, DisplayIdParametersHalfFloatsAndChromaticity) {
  // binary16: 0x6178 = 700, 0x6640 = 1600, 0x4000 = 2 (IEEE 754-2008).
  const auto e = parse_ok(assemble({base_block(1), displayid_block(0x20, {displayid_parameters(false, 0x6178, 0x6640, 0x4000)})}));
  ASSERT_TRUE(e.displayid_parameters);
  const auto& d = *e.displayid_parameters;
  EXPECT_DOUBLE_EQ(d.max_full_cd_m2(), 700.0);
  EXPECT_DOUBLE_EQ(d.max_10pct_cd_m2(), 1600.0);
  EXPECT_DOUBLE_EQ(d.min_cd_m2(), 2.0);
  EXPECT_EQ(d.h_pixels, 3120);
  EXPECT_NEAR(d.primaries.white.x, 1281 / 4096.0, 1e-12);
  EXPECT_NEAR(d.primaries.white.y, 1348 / 4096.0, 1e-12);
  EXPECT_EQ(d.color_depth_bpc(), 12);
  EXPECT_EQ(d.device_technology(), 2);
  EXPECT_TRUE(e.warnings.empty() || !has_warning(e, "checksum"));
}

TEST(EdidParser, DisplayIdCie1976ChromaticityIsConvertedToXy) {
  // D65 in u'v' is (0.1978, 0.4683) -> xy (0.3127, 0.3290); codes 810/4096, 1918/4096.
  const auto e = parse_ok(assemble({base_block(1), displayid_block(0x20, {displayid_parameters(true, 0, 0, 0)})}));
  ASSERT_TRUE(e.displayid_parameters);
  EXPECT_NEAR(e.displayid_parameters->primaries.white.x, 0.3127, 5e-4);
  EXPECT_NEAR(e.displayid_parameters->primaries.white.y, 0.3290, 5e-4);
}

TEST(EdidParser, CtaBlocksInsideDisplayIdAreFound) {
  Block cta_in_did{0x81, 0x00, 0x00};
  for (auto v : cta_extended(0x06, {0x0d, 0x01, 120, 100, 10})) cta_in_did.push_back(v);
  for (auto v : cta_extended(0x05, {0x80, 0x00})) cta_in_did.push_back(v);
  cta_in_did[2] = static_cast<std::uint8_t>(cta_in_did.size() - 3);
  const auto e = parse_ok(assemble({base_block(1), displayid_block(0x20, {cta_in_did})}));
  ASSERT_TRUE(e.hdr_static_metadata);
  EXPECT_EQ(e.hdr_static_metadata->location, "DisplayID extension (block 1), CTA-861 DisplayID Data Block");
  EXPECT_TRUE(e.hdr_static_metadata->hlg());
  ASSERT_TRUE(e.colorimetry);
  EXPECT_TRUE(e.colorimetry->bt2020_rgb());
}

TEST(EdidParser, DisplayIdLengthsThatLieAreWarnings) {
  auto did = displayid_block(0x20, {displayid_parameters(false, 0x6178, 0x6640, 0x4000)});
  did[2] = 200;  // section length beyond the block
  auto e = parse_ok(assemble({base_block(1), did}));
  EXPECT_TRUE(has_warning(e, "section length 200 overruns the block"));

  auto did2 = displayid_block(0x20, {displayid_parameters(false, 0x6178, 0x6640, 0x4000)});
  did2[5 + 2] = 100;  // the parameters block claims 100 bytes in a 32-byte section
  e = parse_ok(assemble({base_block(1), did2}));
  EXPECT_TRUE(has_warning(e, "overruns the section"));
  EXPECT_FALSE(e.displayid_parameters);
}

TEST(EdidParser, NonPrintableNameBytesAreReplacedAndReported) {
  auto b = base_block(0);
  b[72 + 5 + 2] = 0xff;
  const auto e = parse_ok(assemble({b}));
  EXPECT_EQ(e.name, "Te?t Panel");
  EXPECT_TRUE(has_warning(e, "non-printable"));
  EXPECT_NO_THROW((void)edid_to_json(e).dump());  // always valid UTF-8
}

TEST(EdidParser, HalfFloatDecoding) {
  EXPECT_DOUBLE_EQ(half_to_double(0x3c00), 1.0);
  EXPECT_DOUBLE_EQ(half_to_double(0x7bff), 65504.0);
  EXPECT_DOUBLE_EQ(half_to_double(0x0001), std::ldexp(1.0, -24));
  EXPECT_DOUBLE_EQ(half_to_double(0xc000), -2.0);
  EXPECT_TRUE(std::isinf(half_to_double(0x7c00)));
}

// Property over every fixture: any prefix of at least 128 bytes, and any single-byte
// corruption past the header, still parses (never an error) with a bounded warning list.
TEST(EdidParser, EveryFixturePrefixAndCorruptionParses) {
  auto dir = hdrd::testing::fixture("fixtures/edid");
  if (!dir) GTEST_SKIP() << "shared fixture missing: ../shared/fixtures/edid";
  int parsed = 0;
  for (const auto& f : std::filesystem::directory_iterator(*dir)) {
    if (f.path().extension() != ".bin") continue;
    const std::string s = hdrd::testing::read_file(f.path());
    std::vector<std::uint8_t> bytes(s.begin(), s.end());
    for (std::size_t n = 128; n <= bytes.size(); n += 7) {
      auto r = parse_edid(std::span(bytes).first(n));
      ASSERT_TRUE(r.ok()) << f.path() << " prefix " << n;
      EXPECT_LE(r->warnings.size(), 65u);
      ++parsed;
    }
    for (std::size_t i = 8; i < bytes.size(); i += 3) {
      auto copy = bytes;
      copy[i] ^= 0xa5;
      auto r = parse_edid(copy);
      ASSERT_TRUE(r.ok()) << f.path() << " byte " << i;
      EXPECT_FALSE(format_edid_text(*r).empty());
      ++parsed;
    }
  }
  EXPECT_GT(parsed, 1000);
}

}  // namespace
}  // namespace hdrd::display

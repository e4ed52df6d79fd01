// HDR_OUTPUT_METADATA blob bytes against values worked out by hand from CTA-861-G §6.9
// (chromaticity x 50000, luminance in 1 cd/m2, min in 0.0001 cd/m2) and REFERENCE.md §6,
// and the layout against libdrm's own struct hdr_output_metadata.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstring>

#include <drm_mode.h>

#include "display/hdr_metadata.hpp"
#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"

namespace hdrd::display {
namespace {

using Bytes32 = std::array<std::uint8_t, kHdrOutputMetadataSize>;

TEST(HdrOutputMetadata, Hdr10WithP3MasteringByHand) {
  // P3-D65 mastering, 1000 / 0.005 cd/m2, MaxCLL 1000.4 (rounded up, 1001, is above the
  // mastering maximum: carried as 1000, issue 29 item 2), MaxFALL 400.
  MasteringDisplay md{color::kDisplayP3, 1000.0, 0.005};
  auto m = make_hdr_output_metadata(Mode::hdr10, md, ContentLightLevel{1000.4, 400.0});
  ASSERT_TRUE(m.ok()) << m.error().message;
  const Bytes32 expected = {
      0x00, 0x00, 0x00, 0x00,  // metadata_type = HDMI_STATIC_METADATA_TYPE1
      0x02,                    // EOTF: SMPTE ST 2084 (CTA-861-G Table 45)
      0x00,                    // Static_Metadata_Descriptor_ID 0
      0xd0, 0x84, 0x80, 0x3e,  // R 0.680 -> 34000, 0.320 -> 16000
      0xc2, 0x33, 0xc4, 0x86,  // G 0.265 -> 13250, 0.690 -> 34500
      0x4c, 0x1d, 0xb8, 0x0b,  // B 0.150 -> 7500, 0.060 -> 3000
      0x13, 0x3d, 0x42, 0x40,  // W 0.3127 -> 15635, 0.3290 -> 16450
      0xe8, 0x03,              // max mastering 1000 cd/m2
      0x32, 0x00,              // min mastering 0.005 cd/m2 = 50 x 0.0001
      0xe8, 0x03,              // MaxCLL 1000 (never above the mastering maximum)
      0x90, 0x01,              // MaxFALL 400
      0x00, 0x00};             // padding
  EXPECT_EQ(serialize(*m), expected);
}

TEST(HdrOutputMetadata, HlgWithRec2020AndZeroLightLevelFallsBackToThePeak) {
  MasteringDisplay md{color::kRec2020, 600.0, 0.0};
  auto m = make_hdr_output_metadata(Mode::hlg, md, ContentLightLevel{0.0, 0.0});
  ASSERT_TRUE(m.ok());
  const Bytes32 expected = {
      0x00, 0x00, 0x00, 0x00,
      0x03,                    // EOTF: HLG
      0x00,
      0x48, 0x8a, 0x08, 0x39,  // R 0.708 -> 35400, 0.292 -> 14600
      0x34, 0x21, 0xaa, 0x9b,  // G 0.170 -> 8500, 0.797 -> 39850
      0x96, 0x19, 0xfc, 0x08,  // B 0.131 -> 6550, 0.046 -> 2300
      0x13, 0x3d, 0x42, 0x40,  // W D65
      0x58, 0x02,              // max mastering 600
      0x00, 0x00,              // min 0
      0x58, 0x02,              // MaxCLL 0 ("unknown") -> mastering peak 600
      0x58, 0x02,              // MaxFALL likewise
      0x00, 0x00};
  EXPECT_EQ(serialize(*m), expected);
}

TEST(HdrOutputMetadata, RoundingAndClamping) {
  MasteringDisplay md{color::kRec2020, 10000.0, 0.00005};
  auto m = make_hdr_output_metadata(Mode::hdr10, md, ContentLightLevel{70000.0, 0.2});
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->min_display_mastering_luminance, 1);  // 0.5 x 0.0001 rounds to 1
  EXPECT_EQ(m->max_cll, 10000);                      // never above the mastering maximum
  EXPECT_EQ(m->max_fall, 1);                         // 0.2 rounds *up* to 1, not down to "unknown"
  auto up = make_hdr_output_metadata(Mode::hdr10, md, ContentLightLevel{999.4, 250.0});
  EXPECT_EQ(up->max_cll, 1000);  // below the mastering maximum, MaxCLL rounds up
  auto exact = make_hdr_output_metadata(Mode::hdr10, md, ContentLightLevel{1000.0, 250.0});
  EXPECT_EQ(exact->max_cll, 1000);  // an exact integer does not round up
  EXPECT_EQ(exact->max_fall, 250);
}

TEST(HdrOutputMetadata, RejectsSdrAndBadInput) {
  MasteringDisplay md;
  auto sdr = make_hdr_output_metadata(Mode::sdr, md, {});
  ASSERT_FALSE(sdr.ok());
  EXPECT_EQ(sdr.error().message, "HDR output metadata applies to hdr10 and hlg signals, not sdr");
  EXPECT_FALSE(make_hdr_output_metadata(Mode::scrgb, md, {}).ok());
  EXPECT_FALSE(make_hdr_output_metadata(Mode::hdr10, MasteringDisplay{color::kRec2020, 100, 200}, {}).ok());
  EXPECT_FALSE(make_hdr_output_metadata(Mode::hdr10, md, ContentLightLevel{NAN, 1}).ok());
}

TEST(HdrOutputMetadata, LayoutMatchesLibdrmStruct) {
  static_assert(sizeof(hdr_output_metadata) == kHdrOutputMetadataSize);
  auto m = make_hdr_output_metadata(Mode::hdr10, MasteringDisplay{color::kDisplayP3, 1000.0, 0.005},
                                    ContentLightLevel{1000.4, 400.0});
  const auto bytes = serialize(*m);
  hdr_output_metadata k{};
  std::memcpy(&k, bytes.data(), sizeof k);  // x86 is little-endian, as the kernel ABI here
  EXPECT_EQ(k.metadata_type, HDMI_STATIC_METADATA_TYPE1);
  EXPECT_EQ(k.hdmi_metadata_type1.eotf, 2);
  EXPECT_EQ(k.hdmi_metadata_type1.display_primaries[0].x, 34000);
  EXPECT_EQ(k.hdmi_metadata_type1.display_primaries[2].y, 3000);
  EXPECT_EQ(k.hdmi_metadata_type1.white_point.x, 15635);
  EXPECT_EQ(k.hdmi_metadata_type1.max_display_mastering_luminance, 1000);
  EXPECT_EQ(k.hdmi_metadata_type1.min_display_mastering_luminance, 50);
  EXPECT_EQ(k.hdmi_metadata_type1.max_cll, 1000);  // 1000.4 capped at the mastering maximum
  EXPECT_EQ(k.hdmi_metadata_type1.max_fall, 400);
  auto back = parse_hdr_output_metadata(bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, *m);
}

TEST(HdrOutputMetadata, SequenceSendsTheLargestOfEachFrame) {
  const ContentLightLevel frames[] = {{400, 100}, {1200, 90}, {800, 300}};
  const auto s = sequence_light_level(frames);
  EXPECT_EQ(s.max_cll_nits, 1200);
  EXPECT_EQ(s.max_fall_nits, 300);
}

TEST(HdrOutputMetadata, ColorspaceAndKernelConstants) {
  EXPECT_EQ(colorspace_name(Mode::hdr10), "BT2020_RGB");
  EXPECT_EQ(colorspace_name(Mode::hlg), "BT2020_RGB");
  EXPECT_EQ(colorspace_name(Mode::sdr), "Default");
  EXPECT_EQ(DRM_MODE_COLORIMETRY_BT2020_RGB, 9);  // include/drm/drm_connector.h
  EXPECT_EQ(HDMI_STATIC_METADATA_TYPE1, 0);       // include/linux/hdmi.h
}


// One rule for MaxCLL / MaxFALL (encode/frame.hpp, REFERENCE.md §6), carried identically by
// the sidecar, the PNG cLLI and HDR_OUTPUT_METADATA: a black frame carries the mastering
// peak (CTA-861.3 reads 0 as "unknown"), a lit one its measured values rounded up.
TEST(ContentLightEverywhere, BlackAndLitFramesCarryTheSameValuesInEveryContainer) {
  for (Mode mode : {Mode::hdr10, Mode::hlg})
    for (double level : {0.0, 0.37, 4.2}) {
      Image img(8, 4);
      for (std::size_t i = 0; i < img.pixel_count(); ++i)
        img.rgba[i * 4] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = float(level * (i % 3)), img.rgba[i * 4 + 3] = 1;
      EncodeSettings s;
      s.target = default_target(mode);
      s.tone.curve = "clip";
      SceneInput in;
      in.image = &img;
      auto f = encode_frame(in, s);
      ASSERT_TRUE(f.ok());
      const auto sidecar = io::sidecar_json(*f, {});
      const int cll = sidecar["content_light_level"]["max_cll_nits"], fall = sidecar["content_light_level"]["max_fall_nits"];
      if (level == 0) {
        EXPECT_EQ(f->content_light.max_cll_nits, 0.0);
        EXPECT_EQ(cll, 1000) << "a black frame carries the mastering peak";
        EXPECT_EQ(fall, 1000);
      } else {
        EXPECT_EQ(cll, static_cast<int>(std::ceil(f->content_light.max_cll_nits - 1e-6)));
        EXPECT_EQ(fall, static_cast<int>(std::ceil(f->content_light.max_fall_nits - 1e-6)));
      }
      auto png = io::encode_png(*f);
      ASSERT_TRUE(png.ok());
      auto info = io::read_png_info_memory(*png);
      ASSERT_TRUE(info.ok() && info->clli);
      const auto& c = *info->clli;
      EXPECT_EQ((c[0] << 24 | c[1] << 16 | c[2] << 8 | c[3]), cll * 10000) << to_string(mode) << " " << level;
      EXPECT_EQ((c[4] << 24 | c[5] << 16 | c[6] << 8 | c[7]), fall * 10000);
      auto m = make_hdr_output_metadata(mode, f->mastering, f->content_light);
      ASSERT_TRUE(m.ok());
      const auto blob = serialize(*m);
      EXPECT_EQ(blob[26] | (blob[27] << 8), cll);
      EXPECT_EQ(blob[28] | (blob[29] << 8), fall);
    }
}

}  // namespace
}  // namespace hdrd::display

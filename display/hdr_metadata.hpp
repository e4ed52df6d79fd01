// The kernel's HDR_OUTPUT_METADATA connector property blob (struct hdr_output_metadata,
// drm_mode.h), which the driver turns into the CTA-861-G Dynamic Range and Mastering
// InfoFrame (§6.9): EOTF, static metadata type 1 (SMPTE ST 2086 mastering display +
// CTA-861.3 MaxCLL/MaxFALL). Plus the colorimetry values for the "Colorspace" property.
// Built without libdrm so it can be tested byte by byte; drm_device.cpp static_asserts
// the layout against the libdrm header.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "encode/display_target.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"

// linux/hdmi.h values the libdrm 2.4.114 headers lack (REFERENCE.md §6).
#ifndef HDMI_STATIC_METADATA_TYPE1
#define HDMI_STATIC_METADATA_TYPE1 0
#endif
// drm_connector.h DRM_MODE_COLORIMETRY_* (kernel-internal; newer uapi headers export
// them). The "Colorspace" property is an enum: hdrd looks the value up by name and uses
// these only to cross-check and in the fake device.
#ifndef DRM_MODE_COLORIMETRY_DEFAULT
#define DRM_MODE_COLORIMETRY_DEFAULT 0
#define DRM_MODE_COLORIMETRY_NO_DATA 0
#define DRM_MODE_COLORIMETRY_SMPTE_170M_YCC 1
#define DRM_MODE_COLORIMETRY_BT709_YCC 2
#define DRM_MODE_COLORIMETRY_XVYCC_601 3
#define DRM_MODE_COLORIMETRY_XVYCC_709 4
#define DRM_MODE_COLORIMETRY_SYCC_601 5
#define DRM_MODE_COLORIMETRY_OPYCC_601 6
#define DRM_MODE_COLORIMETRY_OPRGB 7
#define DRM_MODE_COLORIMETRY_BT2020_CYCC 8
#define DRM_MODE_COLORIMETRY_BT2020_RGB 9
#define DRM_MODE_COLORIMETRY_BT2020_YCC 10
#define DRM_MODE_COLORIMETRY_DCI_P3_RGB_D65 11
#define DRM_MODE_COLORIMETRY_DCI_P3_RGB_THEATER 12
#define DRM_MODE_COLORIMETRY_RGB_WIDE_FIXED 13
#define DRM_MODE_COLORIMETRY_RGB_WIDE_FLOAT 14
#define DRM_MODE_COLORIMETRY_BT601_YCC 15
#endif

namespace hdrd::display {

// CTA-861-G Table 45 (EOTF field of the InfoFrame); kernel enum hdmi_eotf.
enum class InfoframeEotf : std::uint8_t { traditional_sdr = 0, traditional_hdr = 1, smpte_st2084 = 2, hlg = 3 };

// Mirrors struct hdr_output_metadata { u32 metadata_type; struct hdr_metadata_infoframe }.
struct HdrOutputMetadata {
  std::uint32_t metadata_type = HDMI_STATIC_METADATA_TYPE1;
  InfoframeEotf eotf = InfoframeEotf::smpte_st2084;
  std::uint8_t infoframe_metadata_type = HDMI_STATIC_METADATA_TYPE1;  // Static_Metadata_Descriptor_ID
  // R, G, B (the order gamescope, Weston and KWin fill), then white; units of 0.00002.
  std::array<std::array<std::uint16_t, 2>, 3> display_primaries{};
  std::array<std::uint16_t, 2> white_point{};
  std::uint16_t max_display_mastering_luminance = 0;  // 1 cd/m2
  std::uint16_t min_display_mastering_luminance = 0;  // 0.0001 cd/m2
  std::uint16_t max_cll = 0;                          // 1 cd/m2
  std::uint16_t max_fall = 0;                         // 1 cd/m2
  friend bool operator==(const HdrOutputMetadata&, const HdrOutputMetadata&) = default;
};

// sizeof(struct hdr_output_metadata): 4 + 26, padded to the u32 alignment.
inline constexpr std::size_t kHdrOutputMetadataSize = 32;

// The metadata for an HDR10 or HLG signal: the mastering display (primaries, max = peak,
// min = black) and the measured content light level. MaxCLL/MaxFALL are rounded up to
// 1 cd/m2; a value that would be 0 ("unknown" in CTA-861.3, which some sinks mishandle)
// falls back to the mastering peak. Errors for SDR/scRGB modes and non-finite input.
Result<HdrOutputMetadata> make_hdr_output_metadata(Mode mode, const MasteringDisplay& mastering,
                                                   const ContentLightLevel& light);

// Little-endian bytes of struct hdr_output_metadata (the property blob), and back.
std::array<std::uint8_t, kHdrOutputMetadataSize> serialize(const HdrOutputMetadata& m);
Result<HdrOutputMetadata> parse_hdr_output_metadata(std::span<const std::uint8_t> bytes);

// CTA-861.3 asks for one static set per sequence: the largest MaxCLL and MaxFALL of
// all frames.
ContentLightLevel sequence_light_level(std::span<const ContentLightLevel> frames);

// The "Colorspace" connector enum entry to select for a mode: "BT2020_RGB" for HDR10
// and HLG, "Default" otherwise (sRGB / BT.709 RGB).
std::string_view colorspace_name(Mode mode);

}  // namespace hdrd::display

// HDR10+ dynamic metadata: SMPTE ST 2094-40 application 4 as carried in an ITU-T T.35
// message (HEVC user_data_registered SEI, AV1 METADATA_TYPE_ITUT_T35 OBU), one processing
// window (the whole picture), in the bitstream's own units. Linear light is "linearized
// RGB" normalised to 10 000 cd/m2 in steps of 0.00001, so one unit is 0.1 cd/m2.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/result.hpp"

namespace hdrd::video {

// The percentages of the maxRGB distribution hdrd reports: the nine HDR10+ LLC uses
// (x265's --dhdr10-info samples, hdr10plus_tool).
inline constexpr std::array<int, 9> kHdr10PlusPercentages{1, 5, 10, 25, 50, 75, 90, 95, 99};
inline constexpr double kHdr10PlusUnitNits = 0.1;

struct Hdr10PlusBezier {
  std::uint16_t knee_point_x = 0, knee_point_y = 0;  // 0..4095 (x / 4095 of source and target peak)
  std::vector<std::uint16_t> anchors;                // 0..1023 each, at most 9 (HDR10+ profile B)
};

struct Hdr10PlusFrame {
  // Peak of the display the curve is meant for, cd/m2 (0..10000); 0 without a curve
  // (HDR10+ profile A).
  std::uint32_t targeted_system_display_maximum_luminance = 0;
  std::array<std::uint32_t, 3> maxscl{};  // largest R, G, B, 0.1 cd/m2 units (0..100000)
  std::uint32_t average_maxrgb = 0;       // mean of max(R, G, B), 0.1 cd/m2 units
  struct Percentile {
    std::uint8_t percentage = 0;  // 0..100, strictly increasing
    std::uint32_t value = 0;      // maxRGB at that percentage, 0.1 cd/m2 units, non-decreasing
  };
  std::vector<Percentile> distribution;   // 1..15 entries
  std::uint16_t fraction_bright_pixels = 0;  // 0..1000 (x 0.001); hdrd writes 0, as x265 does
  std::optional<Hdr10PlusBezier> bezier;     // tone_mapping_flag
};

// Every range of ST 2094-40 (and HDR10+'s nine anchors), naming the field.
Result<void> validate(const Hdr10PlusFrame& m);

// The T.35 message from itu_t_t35_country_code on: B5 003C 0001 04 01 + the ST 2094-40
// bits, zero-padded to a byte. The HEVC SEI payload and the AV1 metadata payload alike.
std::vector<std::uint8_t> hdr10plus_t35(const Hdr10PlusFrame& m);

// One SceneInfo entry of the JSON x265's --dhdr10-info reads (HDR10+ LLC layout, as
// hdr10plus_tool writes it).
nlohmann::json hdr10plus_json_entry(const Hdr10PlusFrame& m, int scene_id, int scene_frame_index,
                                    int sequence_frame_index);

}  // namespace hdrd::video

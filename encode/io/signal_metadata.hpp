// What a signal is and the HDR metadata that goes with it, in the integer units every
// carrier shares, so PNG chunks, video bitstreams and containers state the same numbers:
// ITU-T H.273 code points (PNG cICP, HEVC/AV1 VUI and colour config, ISO BMFF colr nclx,
// Matroska Colour), SMPTE ST 2086 mastering display (HEVC SEI 137, PNG mDCV, ISO BMFF
// mdcv: chromaticities in 0.00002, luminance in 0.0001 cd/m2) and CTA-861.3 content light
// (HEVC SEI 144, ISO BMFF clli, Matroska MaxCLL/MaxFALL: whole cd/m2).
#pragma once

#include <array>
#include <cstdint>

#include "encode/display_target.hpp"
#include "encode/frame.hpp"

namespace hdrd::io {

struct H273 {
  std::uint8_t colour_primaries = 1;          // 1 BT.709, 9 BT.2020
  std::uint8_t transfer_characteristics = 13;  // 16 PQ, 18 HLG, 13 sRGB, 4 gamma 2.2, 1 BT.709 (BT.1886 display)
};
// The code points of a target's encoded signal (scRGB has none: linear, no H.273 transfer).
H273 h273_for(const DisplayTarget& t);
// Matrix coefficients (H.273 Table 4) for the forms hdrd writes.
inline constexpr std::uint8_t kH273MatrixIdentity = 0;  // RGB (PNG)
inline constexpr std::uint8_t kH273MatrixBt709 = 1;
inline constexpr std::uint8_t kH273MatrixBt2020Ncl = 9;

// value / unit rounded (up, when round_up: a carrier must never state less light than was
// measured) and clamped to [0, max]; 0 for values <= 0 and NaN.
std::uint32_t to_units(double value, double unit, double max, bool round_up);

struct St2086Codes {
  // x, y of the red, green and blue primaries and the white point, in 0.00002.
  std::array<std::uint16_t, 2> red{}, green{}, blue{}, white{};
  std::uint32_t max_luminance = 0;  // 0.0001 cd/m2
  std::uint32_t min_luminance = 0;  // 0.0001 cd/m2
};
St2086Codes st2086_codes(const MasteringDisplay& m);

struct Cta861Light {
  std::uint16_t max_cll = 0;   // cd/m2
  std::uint16_t max_fall = 0;  // cd/m2
};
// Whole cd/m2, rounded up. 0 means "unknown" and some displays misbehave on it, so a value
// that would be 0 becomes the mastering peak (REFERENCE.md §6); MaxFALL <= MaxCLL.
Cta861Light cta861_light(const ContentLightLevel& light, const MasteringDisplay& m);

}  // namespace hdrd::io

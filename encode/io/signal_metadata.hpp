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

// The H.273 code points of a target's signal are hdrd::h273() (encode/display_target.hpp,
// from the mode table). Matrix coefficients (H.273 Table 4) for the forms hdrd writes:
inline constexpr std::uint8_t kH273MatrixIdentity = 0;  // RGB (PNG, lossless AVIF)
inline constexpr std::uint8_t kH273MatrixBt709 = 1;
inline constexpr std::uint8_t kH273MatrixBt2020Ncl = 9;
// The non-constant-luminance Y'CbCr matrix of the target's container: 9 for Rec.2020, 1 for Rec.709.
std::uint8_t ycbcr_matrix(const DisplayTarget& t);

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
// The values of carried_light_level() (encode/frame.hpp: the one rule for every carrier:
// whole cd/m2 rounded up, 0 -> the mastering peak, MaxFALL <= MaxCLL) in CTA-861.3's form.
Cta861Light cta861_light(const ContentLightLevel& light, const MasteringDisplay& m);

}  // namespace hdrd::io

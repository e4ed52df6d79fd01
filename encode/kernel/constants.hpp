// The numbers the encoder kernels use — the staged path, the SIMD kernel and the generated
// GLSL — each derived from the colour code's named constant, so that no kernel writes a
// literal of its own (REFERENCE.md §1: the CPU colour code is the single source of truth).
// The GLSL program gets them through glsl_constants(), printed at full float precision.
#pragma once

#include <string>

#include "encode/colour/color.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::kernel {

// BT.2100 Table 4 / BT.2020 luminance coefficients (color::kRec2020Luma), as floats.
inline constexpr float kLumaR = static_cast<float>(color::kRec2020Luma.x);
inline constexpr float kLumaG = static_cast<float>(color::kRec2020Luma.y);
inline constexpr float kLumaB = static_cast<float>(color::kRec2020Luma.z);
inline constexpr float rec2020_luminance(float r, float g, float b) { return kLumaR * r + kLumaG * g + kLumaB * b; }

// scRGB: 1.0 = 80 cd/m2 (transfer::kScrgbUnitNits, IEC 61966-2-2).
inline constexpr float kScrgbUnitNits = static_cast<float>(transfer::kScrgbUnitNits);
inline constexpr float kInvScrgbUnitNits = static_cast<float>(1.0 / transfer::kScrgbUnitNits);

// 16-bit PNG samples: round(E' 65535) of a full-range signal; a 10-bit code D as the 16-bit
// sample D 65535 / 1023 (docs/dump-format.md §3).
inline constexpr float kMax16 = 65535.0f;
inline constexpr int kMax10 = 1023;
inline constexpr float kCode10To16 = kMax16 / static_cast<float>(kMax10);

// `const` declarations of the above for the GLSL program (kLuma as a vec3).
std::string glsl_constants();

}  // namespace hdrd::kernel

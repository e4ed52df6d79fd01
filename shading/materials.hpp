// Specular colour (F0) presets as data, from RTR4 tables 9.1-9.4 (REFERENCE.md §5), and
// the conversions to another surrounding medium (water): eq. 9.19 for dielectrics,
// complex-IOR Fresnel for metals.
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include "shading/math.hpp"

namespace hdrd::shading {

enum class PresetKind { dielectric, metal };

struct F0Preset {
  std::string_view name;    // "gold", "skin", ...
  PresetKind kind;
  std::string_view source;  // "RTR4 table 9.2", ...
  Vec3 f0_air;              // linear; dielectrics carry the same value in each channel
  double f0_air_low = 0;    // dielectric range where the table gives one (else = f0_air)
  double f0_air_high = 0;
  std::optional<Vec3> f0_water;  // RTR4 table 9.4, where listed
};

std::span<const F0Preset> f0_presets();
const F0Preset* find_f0_preset(std::string_view name);

inline constexpr double kWaterIor = 1.33;  // RTR4 table 9.4's n1
// Metals without tabulated in-water data assume n = 1 (a middle value; real metals span
// about 0.1 to 3): within 0.03 of table 9.4 for iron, gold and silver.
inline constexpr double kDefaultMetalN = 1.0;

// Eq. 9.17 inverted: real IOR (relative to vacuum/air) of a dielectric from its F0 in air.
double ior_from_f0(double f0_air);
// Eq. 9.19: F0 of a dielectric (given by its in-air F0) against a medium of IOR n1.
double dielectric_f0_in_medium(double f0_air, double medium_ior);

// Metals have a complex IOR n + ik: F0 = ((n - n1)^2 + k^2) / ((n + n1)^2 + k^2).
// Given F0 in air and the real part n per channel, k follows; the F0 against a medium
// n1 is then exact for that n. Identity when medium_ior == 1.
Vec3 metal_f0_in_medium(Vec3 f0_air, Vec3 metal_n, double medium_ior);
// The real part n per channel that reproduces both table values (F0 in air and in water);
// channels with F0 = 1 (or no solution) get `fallback`.
Vec3 metal_n_from_table(Vec3 f0_air, Vec3 f0_water, double fallback = kDefaultMetalN);
// n per channel for a preset: fitted to table 9.4 where it has water data.
Vec3 preset_metal_n(const F0Preset& p);

// Dielectric "specular" parameter (Filament's reflectance): F0 = 0.16 s^2, s = 0.5 -> 0.04.
inline double f0_from_specular(double specular) { return 0.16 * specular * specular; }

}  // namespace hdrd::shading

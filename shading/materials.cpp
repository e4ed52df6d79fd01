#include "shading/materials.hpp"

#include <array>
#include <cmath>

namespace hdrd::shading {
namespace {

constexpr Vec3 grey(double v) { return {v, v, v}; }

constexpr F0Preset dielectric(std::string_view name, double low, double high,
                              std::optional<double> water = std::nullopt,
                              std::string_view source = "RTR4 table 9.1") {
  const double mid = (low + high) / 2;
  return {name, PresetKind::dielectric, source, grey(mid), low, high,
          water ? std::optional<Vec3>(grey(*water)) : std::nullopt};
}

constexpr F0Preset metal(std::string_view name, Vec3 f0, std::optional<Vec3> water = std::nullopt,
                         std::string_view source = "RTR4 table 9.2") {
  return {name, PresetKind::metal, source, f0, 0, 0, water};
}

// REFERENCE.md §5 lists these; ranges become their midpoint. Table 9.4 gives skin,
// Schott K7 glass, diamond, iron, gold and silver in water (n1 = 1.33).
constexpr std::array kPresets{
    dielectric("water", 0.02, 0.02),
    dielectric("skin", 0.028, 0.028, 0.0007),
    dielectric("eyes", 0.025, 0.025),
    dielectric("hair", 0.046, 0.046),
    dielectric("teeth", 0.058, 0.058),
    dielectric("fabric", 0.04, 0.056),
    dielectric("stone", 0.035, 0.056),
    dielectric("plastic", 0.04, 0.05),
    dielectric("glass", 0.04, 0.05),
    dielectric("crystal-glass", 0.05, 0.07),
    dielectric("gems", 0.05, 0.08),
    dielectric("diamond-like", 0.13, 0.2),
    dielectric("k7-glass", 0.042, 0.042, 0.004, "RTR4 table 9.4"),
    dielectric("diamond", 0.172, 0.172, 0.084, "RTR4 table 9.4"),
    metal("titanium", {0.542, 0.497, 0.449}),
    metal("chromium", {0.549, 0.556, 0.554}),
    metal("iron", {0.562, 0.565, 0.578}, Vec3{0.470, 0.475, 0.492}),
    metal("nickel", {0.660, 0.609, 0.526}),
    metal("platinum", {0.673, 0.637, 0.585}),
    metal("copper", {0.955, 0.638, 0.538}),
    metal("palladium", {0.733, 0.697, 0.652}),
    metal("mercury", {0.781, 0.780, 0.778}),
    metal("brass", {0.910, 0.778, 0.423}),
    metal("zinc", {0.664, 0.824, 0.850}),
    metal("gold", {1.000, 0.782, 0.344}, Vec3{1.000, 0.747, 0.261}),
    metal("aluminum", {0.913, 0.922, 0.924}),
    metal("silver", {0.972, 0.960, 0.915}, Vec3{0.964, 0.950, 0.899}),
    // Semiconductor with an RGB F0 (listed with the metals): metalness workflow.
    metal("silicon", {0.345, 0.369, 0.426}, std::nullopt, "RTR4 table 9.2 (semiconductor)"),
};

// F0 of a metal with real IOR n against medium n1, given its F0 in air.
double metal_channel(double f0_air, double n, double n1) {
  if (f0_air >= 0.9999) return f0_air;  // k -> infinity: a perfect reflector stays one
  const double k2 = std::max(0.0, ((n + 1) * (n + 1) * f0_air - (n - 1) * (n - 1)) / (1 - f0_air));
  return ((n - n1) * (n - n1) + k2) / ((n + n1) * (n + n1) + k2);
}

// Smallest n in (0.01, 10) with metal_channel(f0_air, n, water) == f0_water, by a scan
// for the first sign change and bisection.
double solve_n(double f0_air, double f0_water, double fallback) {
  if (f0_air >= 0.9999) return fallback;
  auto g = [&](double n) { return metal_channel(f0_air, n, kWaterIor) - f0_water; };
  double lo = 0.01, glo = g(lo);
  for (double hi = 0.02; hi <= 10.0; hi += 0.01) {
    const double ghi = g(hi);
    if ((glo <= 0) != (ghi <= 0)) {
      for (int i = 0; i < 60; ++i) {
        const double mid = (lo + hi) / 2, gm = g(mid);
        if ((glo <= 0) == (gm <= 0)) { lo = mid; glo = gm; } else { hi = mid; }
      }
      return (lo + hi) / 2;
    }
    lo = hi;
    glo = ghi;
  }
  return fallback;
}

}  // namespace

std::span<const F0Preset> f0_presets() { return kPresets; }

const F0Preset* find_f0_preset(std::string_view name) {
  for (const auto& p : kPresets)
    if (p.name == name) return &p;
  return nullptr;
}

double ior_from_f0(double f0_air) {
  const double s = std::sqrt(std::clamp(f0_air, 0.0, 0.999999));
  return (1 + s) / (1 - s);
}

double dielectric_f0_in_medium(double f0_air, double medium_ior) {
  if (medium_ior == 1.0) return f0_air;
  const double n = ior_from_f0(f0_air);
  const double r = (n - medium_ior) / (n + medium_ior);
  return r * r;
}

Vec3 metal_f0_in_medium(Vec3 f0_air, Vec3 metal_n, double medium_ior) {
  if (medium_ior == 1.0) return f0_air;
  return {metal_channel(f0_air.x, metal_n.x, medium_ior), metal_channel(f0_air.y, metal_n.y, medium_ior),
          metal_channel(f0_air.z, metal_n.z, medium_ior)};
}

Vec3 metal_n_from_table(Vec3 f0_air, Vec3 f0_water, double fallback) {
  return {solve_n(f0_air.x, f0_water.x, fallback), solve_n(f0_air.y, f0_water.y, fallback),
          solve_n(f0_air.z, f0_water.z, fallback)};
}

Vec3 preset_metal_n(const F0Preset& p) {
  if (p.kind == PresetKind::metal && p.f0_water) return metal_n_from_table(p.f0_air, *p.f0_water);
  return grey(kDefaultMetalN);
}

}  // namespace hdrd::shading

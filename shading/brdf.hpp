// CPU reference of the renderer's BRDF, in double precision: the same equations the
// fragment shader evaluates (shading/shaders.cpp), used as the tests' oracle and to
// bake the ambient (uniform environment) lookup table.
//
//   f(l,v) = (1 - F) * rho/pi * (1 - metallic) + F * D * V          (glTF 2.0 App. B)
//   D   GGX / Trowbridge-Reitz, alpha = roughness^2
//   V   Smith height-correlated masking-shadowing, containing 1/(4 n.l n.v)
//   F   Schlick with F0, F90 and exponent 1/p on v.h                 (RTR4 eq. 9.18)
//   Lo  = sum f(l,v) * E * (n.l)+  with c_light = E/pi                 (RTR4 eq. 9.14)
//
// Single-scattering GGX loses energy at high roughness (no multiple-bounce term): a
// rough metal with F0 = 1 reflects about 0.86 of the light at roughness 1 at normal
// view, less at grazing. The glTF coupling's (1 - F(v.h)) diffuse weight is not
// energy-conserving either: with a white base colour its albedo exceeds 1 near grazing
// view (tests/shading/brdf_test.cpp measures both).
#pragma once

#include "shading/math.hpp"

namespace hdrd::shading::brdf {

// Perceptual roughness is clamped to this in the shader and here: alpha = 9e-4 keeps
// D finite in float32 (GGX at alpha -> 0 is a delta).
inline constexpr double kMinRoughness = 0.03;
// Frostbite's n.v handling (REFERENCE.md §5): |n.v| + 1e-5.
inline constexpr double kNdotVBias = 1e-5;

// A surface as the shader sees it after texture fetches, for one medium.
struct Surface {
  Vec3 base_color{1, 1, 1};  // linear Rec.709
  double metallic = 0;
  double roughness = 0.5;         // perceptual; alpha = roughness^2
  double dielectric_f0 = 0.04;    // F0 of the non-metal part, already for the medium
  Vec3 metal_n{1, 1, 1};          // real IOR of the metal per channel (for F0 in other media)
  double medium_ior = 1.0;        // surrounding medium (1 = air, 1.33 = water)
  double f90 = 1.0;
  double fresnel_exponent = 5.0;  // 1/p of eq. 9.18; 5 is Schlick's eq. 9.16
};

// What the lobes need, resolved once per surface point.
struct Lobes {
  Vec3 diffuse_rho;  // rho_ss of the Lambert term (base colour, times 1 - metallic)
  Vec3 f0;
  double f90 = 1;
  double alpha = 0.25;
  double fresnel_exponent = 5;
};
Lobes resolve(const Surface& s);

double ggx_d(double n_dot_h, double alpha);
double smith_v(double n_dot_l, double n_dot_v, double alpha);  // height-correlated, incl. 1/(4 nl nv)
Vec3 schlick(Vec3 f0, double f90, double exponent, double cos_theta);

// The BRDF value f(l, v) per channel (n, l, v unit vectors).
Vec3 evaluate(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v);
// Eq. 9.14 for one light of illuminance `illuminance_lux` (colour included) from l.
Vec3 shade(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v, Vec3 illuminance_lux);

// Directional albedo R(v) = integral of f(l,v) (n.l) over the hemisphere (eq. 9.8),
// by importance sampling (cosine for the diffuse lobe, GGX visible normals for the specular
// lobe) over a Hammersley set of `samples` points.
Vec3 directional_albedo(const Lobes& lobes, double n_dot_v, int samples = 4096);

// The ambient lookup table: for a uniform environment of radiance L, the reflected
// radiance is L * (rho (1-metallic) [(1-F0) d0 + (1-F90) d1] + F0 s0 + F90 s1), where
// s0, s1 are the specular albedo's F0 and F90 parts and d1 = 1 - d0 the diffuse
// weight's F90 part (exponent 5). Indexed by n.v and roughness, each in [0,1].
struct AmbientTerms {
  double s0 = 0, s1 = 0, d1 = 0;
};
AmbientTerms ambient_terms(double n_dot_v, double roughness, int samples = 1024);

// "No real material has F0 < 0.02 in air": F90 fades with F0 (Filament's
// saturate(50 * mean F0)), used only when the medium is air.
double specular_cutoff_f90(Vec3 f0);

}  // namespace hdrd::shading::brdf

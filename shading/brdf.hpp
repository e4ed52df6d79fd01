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
// rough metal with F0 = 1 reflects 1 - ln 2 = 0.307 of the light at roughness 1 at normal
// view. The renderer compensates by default (RenderSettings::energy_compensation):
// punctual lights scale the specular lobe by 1 + F0 (1/E_ss - 1) (Kulla & Conty 2017 in
// Filament's form), environment light adds Fdez-Aguera's (2019) multiple-scattering term
// and takes the diffuse share from what the specular lobes leave. Without compensation the
// glTF coupling's (1 - F(v.h)) diffuse weight is not energy-conserving either: with a white
// base colour its albedo exceeds 1 near grazing view (tests/shading/brdf_test.cpp
// measures both).
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

// The BRDF value f(l, v) per channel (n, l, v unit vectors), the specular lobe times
// `specular_scale` (energy_compensation(), or 1 for single scattering).
Vec3 evaluate(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v, Vec3 specular_scale = {1, 1, 1});
// Eq. 9.14 for one light of illuminance `illuminance_lux` (colour included) from l.
Vec3 shade(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v, Vec3 illuminance_lux, Vec3 specular_scale = {1, 1, 1});

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

// E_ss: the single-scattering specular albedo with F = 1 (s0 + s1 of ambient_terms), by
// visible-normal sampling with `samples` points.
double single_scatter_albedo(double n_dot_v, double roughness, int samples = 4096);
// Kulla & Conty's multiple-scattering factor for punctual lights in Filament's form,
// 1 + F0 (1 / E_ss - 1), per channel.
Vec3 energy_compensation(const Lobes& lobes, double n_dot_v, double roughness, int samples = 4096);

// Reflected radiance under environment light, split-sum style (Karis 2013): `radiance`
// is the prefiltered radiance around the reflection direction, `irradiance_lux` the
// irradiance on the surface; terms from the ambient table at (n.v, roughness). With
// `compensate`: Fdez-Aguera 2019 eqs. 10-13 (F_ms E_ms added, diffuse weighted by
// 1 - (F_ss E_ss + F_ms E_ms)); without: the glTF coupling of the single-scattering terms.
Vec3 environment_response(const Lobes& lobes, const AmbientTerms& terms, Vec3 radiance, Vec3 irradiance_lux,
                          bool compensate);

// "No real material has F0 < 0.02 in air": F90 fades with F0 (Filament's
// saturate(50 * mean F0)), used only when the medium is air.
double specular_cutoff_f90(Vec3 f0);

}  // namespace hdrd::shading::brdf

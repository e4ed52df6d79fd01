#include "shading/brdf.hpp"

#include <cstdint>

#include "shading/materials.hpp"

namespace hdrd::shading::brdf {
namespace {

double saturate(double x) { return std::clamp(x, 0.0, 1.0); }

Vec3 mix(Vec3 a, Vec3 b, double t) { return a * (1 - t) + b * t; }

// Hammersley point i of n: (i/n, radical inverse base 2).
std::pair<double, double> hammersley(std::uint32_t i, std::uint32_t n) {
  std::uint32_t b = i;
  b = (b << 16u) | (b >> 16u);
  b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
  b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
  b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
  b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
  return {(i + 0.5) / n, b * 2.3283064365386963e-10};
}

// Local frame: n = +z, v in the xz plane.
Vec3 view_dir(double n_dot_v) { return {std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v)), 0, n_dot_v}; }

Vec3 cosine_sample(double u1, double u2) {
  const double r = std::sqrt(u1), phi = 2 * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u1))};
}

// A visible normal of GGX for view v (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals"): the estimator f (n.l) / pdf becomes 4 F V (n.l)(n.v) / G1(v) <= F,
// with far less variance at grazing view than sampling D(h)(n.h).
Vec3 ggx_sample_visible_normal(Vec3 v, double alpha, double u1, double u2) {
  const Vec3 vh = normalize(Vec3{alpha * v.x, alpha * v.y, v.z});
  const double lensq = vh.x * vh.x + vh.y * vh.y;
  const Vec3 t1 = lensq > 0 ? Vec3{-vh.y, vh.x, 0} / std::sqrt(lensq) : Vec3{1, 0, 0};
  const Vec3 t2 = cross(vh, t1);
  const double r = std::sqrt(u1), phi = 2 * kPi * u2;
  const double p1 = r * std::cos(phi);
  const double s = 0.5 * (1 + vh.z);
  const double p2 = (1 - s) * std::sqrt(std::max(0.0, 1 - p1 * p1)) + s * r * std::sin(phi);
  const Vec3 nh = t1 * p1 + t2 * p2 + vh * std::sqrt(std::max(0.0, 1 - p1 * p1 - p2 * p2));
  return normalize(Vec3{alpha * nh.x, alpha * nh.y, std::max(0.0, nh.z)});
}

// Smith G1 for GGX: 2 (n.v) / ((n.v) + sqrt(alpha^2 + (1 - alpha^2)(n.v)^2)).
double smith_g1(double n_dot_v, double alpha) {
  const double a2 = alpha * alpha;
  return 2 * n_dot_v / (n_dot_v + std::sqrt(a2 + (1 - a2) * n_dot_v * n_dot_v));
}

// One specular sample for view v: the reflected l and the weight f_s(n.l)/pdf without F.
struct SpecSample {
  Vec3 l;
  double v_dot_h = 0;
  double weight = 0;
};
SpecSample specular_sample(Vec3 v, double n_dot_v, double alpha, double u1, double u2) {
  const Vec3 h = ggx_sample_visible_normal(v, alpha, u1, u2);
  SpecSample s;
  s.v_dot_h = dot(v, h);
  s.l = h * (2 * s.v_dot_h) - v;
  if (s.l.z <= 0 || s.v_dot_h <= 0) return s;
  s.weight = 4 * smith_v(s.l.z, n_dot_v, alpha) * s.l.z * n_dot_v / smith_g1(n_dot_v, alpha);
  return s;
}

}  // namespace

Lobes resolve(const Surface& s) {
  Lobes o;
  const double metallic = saturate(s.metallic);
  const Vec3 metal_f0 = metal_f0_in_medium(s.base_color, s.metal_n, s.medium_ior);
  o.f0 = mix(Vec3{s.dielectric_f0, s.dielectric_f0, s.dielectric_f0}, metal_f0, metallic);
  o.diffuse_rho = s.base_color * (1 - metallic);
  o.f90 = s.f90 * (s.medium_ior == 1.0 ? specular_cutoff_f90(o.f0) : 1.0);
  const double r = std::clamp(s.roughness, kMinRoughness, 1.0);
  o.alpha = r * r;
  o.fresnel_exponent = s.fresnel_exponent;
  return o;
}

double specular_cutoff_f90(Vec3 f0) { return saturate(50.0 * (f0.x + f0.y + f0.z) / 3.0); }

// GGX written as a^2 / (pi ((n.h a)^2 + (1 - (n.h)^2))^2), equal to the usual form
// but without the cancellation of (n.h)^2 (a^2 - 1) + 1 near n.h = 1 in float32.
double ggx_d(double n_dot_h, double alpha) {
  const double one_minus = std::max(0.0, 1 - n_dot_h * n_dot_h);
  const double a = n_dot_h * alpha;
  const double k = alpha / (one_minus + a * a);
  return k * k / kPi;
}

double smith_v(double n_dot_l, double n_dot_v, double alpha) {
  const double a2 = alpha * alpha;
  const double gv = n_dot_l * std::sqrt(n_dot_v * n_dot_v * (1 - a2) + a2);
  const double gl = n_dot_v * std::sqrt(n_dot_l * n_dot_l * (1 - a2) + a2);
  const double denom = gv + gl;
  return denom > 0 ? 0.5 / denom : 0.0;
}

Vec3 schlick(Vec3 f0, double f90, double exponent, double cos_theta) {
  const double s = std::pow(1 - saturate(cos_theta), exponent);
  return f0 + (Vec3{f90, f90, f90} - f0) * s;
}

Vec3 evaluate(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v, Vec3 specular_scale) {
  const double nl = saturate(dot(n, l));
  if (nl <= 0) return {0, 0, 0};
  const double nv = std::abs(dot(n, v)) + kNdotVBias;
  const Vec3 h = normalize(l + v);
  const double nh = saturate(dot(n, h)), vh = saturate(dot(v, h));
  const Vec3 F = schlick(lobes.f0, lobes.f90, lobes.fresnel_exponent, vh);
  const Vec3 diffuse = (Vec3{1, 1, 1} - F) * lobes.diffuse_rho / kPi;
  const Vec3 specular = F * specular_scale * (ggx_d(nh, lobes.alpha) * smith_v(nl, nv, lobes.alpha));
  return diffuse + specular;
}

Vec3 shade(const Lobes& lobes, Vec3 n, Vec3 l, Vec3 v, Vec3 illuminance_lux, Vec3 specular_scale) {
  return evaluate(lobes, n, l, v, specular_scale) * illuminance_lux * saturate(dot(n, l));
}

Vec3 directional_albedo(const Lobes& lobes, double n_dot_v, int samples) {
  const Vec3 v = view_dir(n_dot_v);  // n = +z
  Vec3 sum{0, 0, 0};
  const auto count = static_cast<std::uint32_t>(samples);
  for (std::uint32_t i = 0; i < count; ++i) {
    const auto [u1, u2] = hammersley(i, count);
    // Diffuse lobe, cosine-sampled: f_d (n.l) / pdf = (1 - F) rho.
    const Vec3 ld = cosine_sample(u1, u2);
    const double vh_d = saturate(dot(v, normalize(ld + v)));
    sum = sum + (Vec3{1, 1, 1} - schlick(lobes.f0, lobes.f90, lobes.fresnel_exponent, vh_d)) * lobes.diffuse_rho;
    // Specular lobe over visible normals.
    const double nv = std::abs(n_dot_v) + kNdotVBias;
    const SpecSample sp = specular_sample(v, nv, lobes.alpha, u1, u2);
    if (sp.weight > 0) sum = sum + schlick(lobes.f0, lobes.f90, lobes.fresnel_exponent, sp.v_dot_h) * sp.weight;
  }
  return sum / static_cast<double>(count);
}

AmbientTerms ambient_terms(double n_dot_v, double roughness, int samples) {
  const double r = std::clamp(roughness, kMinRoughness, 1.0), alpha = r * r;
  const Vec3 v = view_dir(std::max(n_dot_v, 1e-4));
  AmbientTerms t;
  const auto count = static_cast<std::uint32_t>(samples);
  for (std::uint32_t i = 0; i < count; ++i) {
    const auto [u1, u2] = hammersley(i, count);
    const Vec3 ld = cosine_sample(u1, u2);
    t.d1 += std::pow(1 - saturate(dot(v, normalize(ld + v))), 5.0);
    const SpecSample sp = specular_sample(v, v.z + kNdotVBias, alpha, u1, u2);
    const double s = std::pow(1 - saturate(sp.v_dot_h), 5.0);
    t.s0 += (1 - s) * sp.weight;
    t.s1 += s * sp.weight;
  }
  t.s0 /= count;
  t.s1 /= count;
  t.d1 /= count;
  return t;
}

double single_scatter_albedo(double n_dot_v, double roughness, int samples) {
  Lobes white;
  white.diffuse_rho = {0, 0, 0};
  white.f0 = {1, 1, 1};
  white.f90 = 1;
  const double r = std::clamp(roughness, kMinRoughness, 1.0);
  white.alpha = r * r;
  return directional_albedo(white, n_dot_v, samples).x;
}

Vec3 energy_compensation(const Lobes& lobes, double n_dot_v, double roughness, int samples) {
  const double ess = single_scatter_albedo(n_dot_v, roughness, samples);
  return Vec3{1, 1, 1} + lobes.f0 * (1 / ess - 1);
}

Vec3 environment_response(const Lobes& lobes, const AmbientTerms& t, Vec3 radiance, Vec3 irradiance_lux,
                          bool compensate) {
  const Vec3 one{1, 1, 1};
  const Vec3 f90{lobes.f90, lobes.f90, lobes.f90};
  const Vec3 fss_ess = lobes.f0 * t.s0 + f90 * t.s1;
  const Vec3 diffuse_light = irradiance_lux / kPi;
  if (!compensate) {
    const Vec3 kd = (one - lobes.f0) * (1 - t.d1) + (one - f90) * t.d1;
    return fss_ess * radiance + lobes.diffuse_rho * kd * diffuse_light;
  }
  const double ess = t.s0 + t.s1, ems = 1 - ess;
  // Schlick's F averaged over the cosine-weighted hemisphere: F0 + (F90 - F0) / 21.
  const Vec3 f_avg = lobes.f0 + (f90 - lobes.f0) * (1.0 / 21.0);
  const Vec3 denom = one - f_avg * ems;
  const Vec3 f_ms_ems = fss_ess * f_avg * ems * Vec3{1 / denom.x, 1 / denom.y, 1 / denom.z};  // eq. 12 times E_ms
  return fss_ess * radiance + f_ms_ems * diffuse_light + lobes.diffuse_rho * (one - fss_ess - f_ms_ems) * diffuse_light;
}

}  // namespace hdrd::shading::brdf

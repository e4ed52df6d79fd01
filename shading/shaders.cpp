#include "shading/shaders.hpp"

#include <fmt/format.h>

#include "shading/brdf.hpp"
#include "shading/gl_util.hpp"
#include "shading/gpu_blocks.hpp"

namespace hdrd::shading::shaders {
namespace {

// Constants the C++ side owns, printed into every lit shader.
std::string constants() {
  return fmt::format(
      "#define MAX_LIGHTS {}\n#define MIN_ROUGHNESS {:.9g}\n#define NDOTV_BIAS {:.9g}\n#define AMBIENT_LUT_SIZE {}\n"
      "#define TEX_BASE {}\n#define TEX_MR {}\n#define TEX_NORMAL {}\n#define TEX_EMISSIVE {}\n#define TEX_OCCLUSION {}\n"
      "#define UNIT_BASE {}\n#define UNIT_MR {}\n#define UNIT_NORMAL {}\n#define UNIT_EMISSIVE {}\n"
      "#define UNIT_OCCLUSION {}\n#define UNIT_SHADOW {}\n#define UNIT_AMBIENT {}\n#define UNIT_ENV_SPECULAR {}\n"
      "#define UNIT_ENV_IRRADIANCE {}\n#define UNIT_ENV_BACKGROUND {}\n#define ENV_NONE {}\n#define ENV_UNIFORM {}\n"
      "#define ENV_MAP {}\n",
      gpu::kMaxLights, brdf::kMinRoughness, brdf::kNdotVBias, gpu::kAmbientLutSize, gpu::kTexBaseColor,
      gpu::kTexMetalRough, gpu::kTexNormal, gpu::kTexEmissive, gpu::kTexOcclusion, int(gpu::kUnitBaseColor),
      int(gpu::kUnitMetalRough), int(gpu::kUnitNormal), int(gpu::kUnitEmissive), int(gpu::kUnitOcclusion),
      int(gpu::kUnitShadow), int(gpu::kUnitAmbientLut), int(gpu::kUnitEnvSpecular), int(gpu::kUnitEnvIrradiance),
      int(gpu::kUnitEnvBackground), gpu::kEnvNone, gpu::kEnvUniform, gpu::kEnvMap);
}

// The blocks of gpu_blocks.hpp, member for member.
constexpr const char* kBlocks = R"(
layout(std140, binding = 0) uniform Frame {
  mat4 view_proj;
  mat4 light_clip;
  mat4 inv_view_proj;
  mat4 env_rotation;
  vec4 camera_pos;
  vec4 ambient_nits;
  vec4 params;
  vec4 shadow_params;
  vec4 env_params;
  vec4 sun_disc;
  vec4 sun_radiance;
  vec4 options;
};
struct Light {
  vec4 color_intensity;
  vec4 position_type;
  vec4 direction_range;
  vec4 spot;
};
layout(std140, binding = 1) uniform Lights { Light lights[MAX_LIGHTS]; };
layout(std140, binding = 2) uniform Draw {
  mat4 model;
  mat4 normal_matrix;
  vec4 base_color;
  vec4 emissive_nits;
  vec4 surface;
  vec4 extra;
  vec4 metal_n;
  ivec4 flags;
};
)";

constexpr const char* kLitVertex = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
out vec3 v_world;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
void main() {
  vec4 w = model * vec4(a_position, 1.0);
  v_world = w.xyz;
  v_normal = mat3(normal_matrix) * a_normal;
  v_tangent = vec4(mat3(model) * a_tangent.xyz, a_tangent.w * float(flags.w));
  v_uv = a_uv;
  gl_Position = view_proj * w;
}
)";

constexpr const char* kMath = R"(
const float PI = 3.14159265358979;

// Equirectangular coordinates (environment.hpp's equirect_uv): u = 0.5 + azimuth / 2 pi
// with the azimuth from -z toward +x, v = zenith angle / pi.
vec2 equirect_uv(vec3 d) {
  return vec2(0.5 + atan(d.x, -d.z + 1e-30) * (0.5 / PI), acos(clamp(d.y, -1.0, 1.0)) * (1.0 / PI));
}
)";

// The BRDF of shading/brdf.cpp, line for line (the CPU version is the tests' oracle).
constexpr const char* kBrdf = R"(
// GGX (RTR4 eq. 9.41) as alpha^2 / (pi ((n.h alpha)^2 + |n x h|^2)^2): no cancellation
// of (n.h)^2 (alpha^2 - 1) + 1 near n.h = 1 in float32.
float ggx_d(vec3 n, vec3 h, float nh, float alpha) {
  vec3 nxh = cross(n, h);
  float a = nh * alpha;
  float k = alpha / (dot(nxh, nxh) + a * a);
  return k * k * (1.0 / PI);
}

// Smith height-correlated masking-shadowing, including 1 / (4 n.l n.v) (Heitz 2014).
float smith_v(float nl, float nv, float alpha) {
  float a2 = alpha * alpha;
  float gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
  float gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
  return 0.5 / (gv + gl);
}

// Schlick with F90 and exponent (RTR4 eq. 9.18), on v.h inside the microfacet BRDF.
vec3 schlick(vec3 f0, float f90, float exponent, float c) {
  return f0 + (vec3(f90) - f0) * pow(1.0 - clamp(c, 0.0, 1.0), exponent);
}

struct Lobes {
  vec3 rho;      // Lambert albedo (1 - metallic) * base colour
  vec3 f0;
  float f90;
  float alpha;
  float exponent;
};

// glTF coupling: f = (1 - F) rho / pi + F D V, the specular lobe times `ms` (the
// multiple-scattering factor 1 + F0 (1/E_ss - 1), or 1).
vec3 brdf(Lobes s, vec3 n, vec3 l, vec3 v, float nl, float nv, vec3 ms) {
  vec3 h = normalize(l + v);
  float nh = clamp(dot(n, h), 0.0, 1.0);
  float vh = clamp(dot(v, h), 0.0, 1.0);
  vec3 F = schlick(s.f0, s.f90, s.exponent, vh);
  return (vec3(1.0) - F) * s.rho * (1.0 / PI) + F * ms * (ggx_d(n, h, nh, s.alpha) * smith_v(nl, nv, s.alpha));
}

// Environment light, split sum (brdf::environment_response line for line). k: s0, s1, d1
// of the ambient table; radiance prefiltered around the reflection; irradiance in lux.
vec3 environment_light(Lobes s, vec3 k, vec3 radiance, vec3 irradiance, bool compensate) {
  vec3 fss_ess = s.f0 * k.x + vec3(s.f90 * k.y);
  vec3 diffuse_light = irradiance * (1.0 / PI);
  if (!compensate) {
    vec3 kd = (vec3(1.0) - s.f0) * (1.0 - k.z) + vec3((1.0 - s.f90) * k.z);
    return fss_ess * radiance + s.rho * kd * diffuse_light;
  }
  float ems = 1.0 - (k.x + k.y);
  vec3 f_avg = s.f0 + (vec3(s.f90) - s.f0) * (1.0 / 21.0);  // Fdez-Aguera 2019 eq. 12
  vec3 f_ms_ems = fss_ess * f_avg * ems / (vec3(1.0) - f_avg * ems);
  return fss_ess * radiance + f_ms_ems * diffuse_light + s.rho * (vec3(1.0) - fss_ess - f_ms_ems) * diffuse_light;
}

// Metals against a medium n1 from F0 in air and the real IOR n (materials.cpp).
vec3 metal_f0_in_medium(vec3 r, vec3 n, float n1) {
  if (n1 == 1.0) return r;
  vec3 rc = min(r, vec3(0.9999));
  vec3 k2 = max(((n + 1.0) * (n + 1.0) * rc - (n - 1.0) * (n - 1.0)) / (1.0 - rc), vec3(0.0));
  vec3 w = ((n - n1) * (n - n1) + k2) / ((n + n1) * (n + n1) + k2);
  return mix(w, r, step(vec3(0.9999), r));
}
)";

constexpr const char* kLitFragment = R"(
in vec3 v_world;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
layout(location = 0) out vec4 o_color;
layout(binding = UNIT_BASE) uniform sampler2D u_base;
layout(binding = UNIT_MR) uniform sampler2D u_mr;
layout(binding = UNIT_NORMAL) uniform sampler2D u_normal;
layout(binding = UNIT_EMISSIVE) uniform sampler2D u_emissive;
layout(binding = UNIT_OCCLUSION) uniform sampler2D u_occlusion;
layout(binding = UNIT_SHADOW) uniform sampler2DShadow u_shadow;
layout(binding = UNIT_AMBIENT) uniform sampler2D u_ambient;
layout(binding = UNIT_ENV_SPECULAR) uniform samplerCube u_env_specular;
layout(binding = UNIT_ENV_IRRADIANCE) uniform samplerCube u_env_irradiance;

// 3x3 PCF over the hardware 2x2 comparison; normal offset against acne.
float shadow_visibility(vec3 p, vec3 ng, vec3 l) {
  float slope = sqrt(max(1.0 - dot(ng, l) * dot(ng, l), 0.0));
  vec4 s = light_clip * vec4(p + ng * shadow_params.x * (0.5 + slope), 1.0);
  vec3 c = s.xyz / s.w * 0.5 + 0.5;
  if (any(lessThan(c, vec3(0.0))) || any(greaterThan(c, vec3(1.0)))) return 1.0;
  float sum = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x)
      sum += texture(u_shadow, vec3(c.xy + vec2(x, y) * shadow_params.y, c.z));
  return sum / 9.0;
}

// The range window: the squared form (1 - (d/r)^4)^2 of Karis 2013 (UE4; also Filament's),
// 1 at r = 0 (no range). KHR_lights_punctual's README recommends the unsquared
// clamp(1 - (d/r)^4, 0, 1) and allows "some non-quadratic falloff near the edge of the
// range": hdrd implements the squared one, which reaches zero with zero slope.
float range_window(float d2, float range) {
  if (range <= 0.0) return 1.0;
  float q = d2 / (range * range);
  float w = clamp(1.0 - q * q, 0.0, 1.0);
  return w * w;
}

// Split-sum terms of the uniform environment (brdf::ambient_terms), bilinear by hand
// so that float textures need no filtering extension.
vec3 ambient_terms(float nv, float roughness) {
  vec2 f = clamp(vec2(nv, roughness), 0.0, 1.0) * float(AMBIENT_LUT_SIZE - 1);
  ivec2 i0 = ivec2(floor(f));
  ivec2 i1 = min(i0 + 1, ivec2(AMBIENT_LUT_SIZE - 1));
  vec2 t = f - vec2(i0);
  vec3 a = mix(texelFetch(u_ambient, ivec2(i0.x, i0.y), 0).rgb, texelFetch(u_ambient, ivec2(i1.x, i0.y), 0).rgb, t.x);
  vec3 b = mix(texelFetch(u_ambient, ivec2(i0.x, i1.y), 0).rgb, texelFetch(u_ambient, ivec2(i1.x, i1.y), 0).rgb, t.x);
  return mix(a, b, t.y);
}

// Frostbite's dominant direction of the specular lobe (Lagarde & de Rousiers 2014,
// §4.9.3): rough lobes lean from the mirror direction toward the normal.
vec3 specular_dominant_direction(vec3 n, vec3 r, float alpha) {
  float smooth_ = clamp(1.0 - alpha, 0.0, 1.0);
  return normalize(mix(n, r, smooth_ * (sqrt(smooth_) + alpha)));
}

// Radiance around r and irradiance on n from the environment (mode ENV_UNIFORM or ENV_MAP).
void environment_lookup(vec3 n, vec3 r, float roughness, out vec3 radiance, out vec3 irradiance) {
  if (int(env_params.z) == ENV_UNIFORM) {
    radiance = ambient_nits.rgb;
    irradiance = PI * ambient_nits.rgb;
    return;
  }
  mat3 rot = mat3(env_rotation);
  radiance = textureLod(u_env_specular, rot * r, roughness * env_params.y).rgb * env_params.x;
  irradiance = texture(u_env_irradiance, rot * n).rgb * env_params.x;
}

vec3 shading_normal(vec3 ng, bool back) {
  if ((flags.x & TEX_NORMAL) == 0) return ng;
  vec3 t = v_tangent.xyz - ng * dot(ng, v_tangent.xyz);
  if (dot(t, t) < 1e-20) return ng;
  t = normalize(t);
  if (back) t = -t;
  vec3 b = cross(ng, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);
  vec3 tn = texture(u_normal, v_uv).xyz * 2.0 - 1.0;
  tn.xy *= extra.y;
  return normalize(mat3(t, b, ng) * tn);
}

void main() {
  vec4 base = base_color;
  if ((flags.x & TEX_BASE) != 0) base *= texture(u_base, v_uv);
  if (flags.y == 1 && base.a < metal_n.w) discard;

  float metallic = surface.x, roughness = surface.y;
  if ((flags.x & TEX_MR) != 0) {
    vec4 mr = texture(u_mr, v_uv);
    roughness *= mr.g;
    metallic *= mr.b;
  }
  metallic = clamp(metallic, 0.0, 1.0);
  roughness = clamp(roughness, MIN_ROUGHNESS, 1.0);

  bool back = !gl_FrontFacing && flags.z != 0;
  vec3 ng = normalize(v_normal);
  if (back) ng = -ng;
  vec3 n = shading_normal(ng, back);
  vec3 v = normalize(camera_pos.xyz - v_world);
  float nv = abs(dot(n, v)) + NDOTV_BIAS;

  float medium = params.y;
  Lobes s;
  s.rho = base.rgb * (1.0 - metallic);
  s.f0 = mix(vec3(surface.z), metal_f0_in_medium(base.rgb, metal_n.xyz, medium), metallic);
  // "F0 < 0.02 means no specular" holds in air only (under water skin has F0 0.0007).
  s.f90 = surface.w * (medium == 1.0 ? clamp(50.0 * dot(s.f0, vec3(1.0 / 3.0)), 0.0, 1.0) : 1.0);
  s.alpha = roughness * roughness;
  s.exponent = extra.x;

  vec3 k = ambient_terms(nv, roughness);  // x: s0, y: s1, z: d1
  bool compensate = options.x > 0.5;
  // Kulla & Conty via Filament: the specular lobe times 1 + F0 (1/E_ss - 1), E_ss = s0 + s1.
  vec3 ms = compensate ? vec3(1.0) + s.f0 * (1.0 / max(k.x + k.y, 1e-4) - 1.0) : vec3(1.0);

  vec3 color = vec3(0.0);
  int count = int(params.z);
  for (int i = 0; i < count; ++i) {
    Light li = lights[i];
    vec3 e = li.color_intensity.rgb;  // illuminance (lux) at normal incidence
    vec3 l;
    int type = int(li.position_type.w);
    if (type == 0) {
      l = -li.direction_range.xyz;
    } else {
      vec3 d = li.position_type.xyz - v_world;
      float d2 = max(dot(d, d), 1e-8);
      l = d * inversesqrt(d2);
      e *= range_window(d2, li.direction_range.w) / d2;  // I / d^2
      if (type == 2) {
        float t = clamp(dot(li.direction_range.xyz, -l) * li.spot.x + li.spot.y, 0.0, 1.0);
        e *= t * t;
      }
    }
    float nl = clamp(dot(n, l), 0.0, 1.0);
    if (nl <= 0.0) continue;
    if (li.spot.z > 0.5 && params.w > 0.5) e *= shadow_visibility(v_world, ng, l);
    color += brdf(s, n, l, v, nl, nv, ms) * e * nl;  // RTR4 eq. 9.14 with c_light = E / pi
  }

  if (int(env_params.z) != ENV_NONE) {
    vec3 r = specular_dominant_direction(n, reflect(-v, n), s.alpha);
    vec3 radiance, irradiance;
    environment_lookup(n, r, roughness, radiance, irradiance);
    float ao = 1.0;
    if ((flags.x & TEX_OCCLUSION) != 0) ao = 1.0 + extra.z * (texture(u_occlusion, v_uv).r - 1.0);
    color += environment_light(s, k, radiance, irradiance, compensate) * (ao * extra.w);
  }

  vec3 emission = emissive_nits.rgb;
  if ((flags.x & TEX_EMISSIVE) != 0) emission *= texture(u_emissive, v_uv).rgb;
  color += emission;

  // Pre-exposure keeps FP16 targets in range (the readback divides it out); the clamp
  // makes an FP16 overflow read 65504 on every GPU (llvmpipe clamps, others give Inf).
  o_color = vec4(min(color * params.x, vec3(shadow_params.z)), flags.y == 2 ? base.a : 1.0);
}
)";

// The environment behind everything: a full-screen triangle on the far plane (drawn
// where the depth buffer is still clear), the view ray through each pixel looking up the
// equirectangular map, plus the sky's sun disc at its physical radiance.
constexpr const char* kBackgroundVertex = R"(
out vec2 v_ndc;
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  v_ndc = p;
  gl_Position = vec4(p, 1.0, 1.0);
}
)";

constexpr const char* kBackgroundFragment = R"(
in vec2 v_ndc;
layout(location = 0) out vec4 o_color;
layout(binding = UNIT_ENV_BACKGROUND) uniform sampler2D u_background;
void main() {
  vec4 far_point = inv_view_proj * vec4(v_ndc, 1.0, 1.0);
  vec3 dir = normalize(far_point.xyz / far_point.w - camera_pos.xyz);
  vec3 c = textureLod(u_background, equirect_uv(mat3(env_rotation) * dir), env_params.w).rgb * env_params.x;
  if (sun_radiance.w > 0.5 && dot(dir, sun_disc.xyz) >= sun_disc.w) c += sun_radiance.rgb;
  o_color = vec4(min(c * params.x, vec3(shadow_params.z)), 1.0);
}
)";

// Cube-map faces for the prefilter passes: the view direction of a face texel
// (environment.hpp's cube_faces(), passed in as uniforms).
constexpr const char* kCubeFace = R"(
in vec2 v_uv;
layout(location = 0) out vec4 o_color;
uniform vec3 u_major;
uniform vec3 u_s_axis;
uniform vec3 u_t_axis;
vec3 face_direction() {
  return normalize(u_major + u_s_axis * (2.0 * v_uv.x - 1.0) + u_t_axis * (2.0 * v_uv.y - 1.0));
}
)";

constexpr const char* kEquirectToCube = R"(
layout(binding = 0) uniform sampler2D u_equirect;
uniform float u_lod;  // the source level whose texels match the face's
void main() { o_color = vec4(textureLod(u_equirect, equirect_uv(face_direction()), u_lod).rgb, 1.0); }
)";

// GGX prefiltering with n = v = r (the split sum, Karis 2013), importance-sampled over a
// Hammersley set and weighted by n.l as Karis does, each sample read from the source mip
// whose texels match the sample's solid angle (filtered importance sampling, Krivanek &
// Colbert 2008, with their +1 bias): few samples, no fireflies from small bright
// sources. Weighting by Smith's G2 instead (exact at normal view) measured worse against
// Monte Carlo over a whole sphere (tests/shading/environment_render_test.cpp).
constexpr const char* kPrefilterGgx = R"(
layout(binding = 0) uniform samplerCube u_source;
uniform float u_alpha;     // GGX alpha of this level; 0 copies the source
uniform int u_samples;
uniform float u_texel_sr;  // solid angle of a level-0 source texel
uniform float u_max_lod;
void main() {
  vec3 n = face_direction();
  if (u_alpha <= 0.0) {
    o_color = vec4(textureLod(u_source, n, 0.0).rgb, 1.0);
    return;
  }
  vec3 up = abs(n.y) < 0.999 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
  vec3 tx = normalize(cross(up, n));
  vec3 ty = cross(n, tx);
  float a2 = u_alpha * u_alpha;
  uint count = uint(u_samples);
  vec3 sum = vec3(0.0);
  float weight = 0.0;
  for (uint i = 0u; i < count; ++i) {
    float u1 = (float(i) + 0.5) / float(count);
    float u2 = float(bitfieldReverse(i)) * 2.3283064365386963e-10;
    float denom = 1.0 + (a2 - 1.0) * u1;
    float cos2 = (1.0 - u1) / denom, sin2 = a2 * u1 / denom;  // h ~ D(h) (n.h)
    float cos_h = sqrt(cos2);
    float phi = 2.0 * PI * u2;
    vec3 h = (tx * cos(phi) + ty * sin(phi)) * sqrt(sin2) + n * cos_h;
    vec3 l = 2.0 * cos_h * h - n;
    float nl = dot(n, l);
    if (nl <= 0.0) continue;
    float q = a2 * cos2 + sin2;
    float pdf = a2 / (4.0 * PI * q * q);  // D(h) (n.h) / (4 v.h) with v = n
    float lod = clamp(0.5 * log2(1.0 / (float(count) * pdf * u_texel_sr)) + 1.0, 0.0, u_max_lod);
    sum += textureLod(u_source, l, lod).rgb * nl;
    weight += nl;
  }
  o_color = vec4(sum / max(weight, 1e-8), 1.0);
}
)";

constexpr const char* kShadowVertex = R"(
layout(location = 0) in vec3 a_position;
void main() { gl_Position = light_clip * (model * vec4(a_position, 1.0)); }
)";

constexpr const char* kShadowFragment = R"(
void main() {}
)";

constexpr const char* kResolveFragment = R"(
in vec2 v_uv;
layout(location = 0) out vec4 o_color;
layout(binding = 0) uniform sampler2DMS u_src;
uniform int u_samples;
uniform float u_weight_exposure;  // scale to "white card = 1" units
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 sum = vec3(0.0);
  float wsum = 0.0;
  for (int i = 0; i < u_samples; ++i) {
    vec3 c = max(texelFetch(u_src, p, i).rgb, vec3(0.0));
    float w = 1.0 / (1.0 + u_weight_exposure * dot(c, vec3(0.2126, 0.7152, 0.0722)));
    sum += c * w;
    wsum += w;
  }
  o_color = vec4(sum / wsum, 1.0);
}
)";

constexpr const char* kReduceFragment = R"(
layout(location = 0) out vec4 o_color;
layout(binding = 0) uniform sampler2D u_src;
uniform int u_block;
uniform ivec2 u_size;
uniform float u_scale;
void main() {
  ivec2 base = ivec2(gl_FragCoord.xy) * u_block;
  vec3 sum = vec3(0.0);
  int n = 0;
  for (int y = 0; y < u_block; ++y)
    for (int x = 0; x < u_block; ++x) {
      ivec2 p = base + ivec2(x, y);
      if (p.x < u_size.x && p.y < u_size.y) {
        sum += texelFetch(u_src, p, 0).rgb;
        ++n;
      }
    }
  o_color = vec4(sum / float(max(n, 1)) * u_scale, 1.0);
}
)";

std::string head(const GlApi& gl) { return glsl_preamble(gl) + constants(); }

}  // namespace

std::string lit_vertex(const GlApi& gl) { return head(gl) + kBlocks + kLitVertex; }
std::string lit_fragment(const GlApi& gl) { return head(gl) + kBlocks + kMath + kBrdf + kLitFragment; }
std::string background_vertex(const GlApi& gl) { return glsl_preamble(gl) + kBackgroundVertex; }
std::string background_fragment(const GlApi& gl) { return head(gl) + kBlocks + kMath + kBackgroundFragment; }
std::string equirect_to_cube_fragment(const GlApi& gl) { return head(gl) + kMath + kCubeFace + kEquirectToCube; }
std::string prefilter_ggx_fragment(const GlApi& gl) { return head(gl) + kMath + kCubeFace + kPrefilterGgx; }
std::string shadow_vertex(const GlApi& gl) { return head(gl) + kBlocks + kShadowVertex; }
std::string shadow_fragment(const GlApi& gl) { return glsl_preamble(gl) + kShadowFragment; }
std::string fullscreen_vertex(const GlApi& gl) { return glsl_preamble(gl) + std::string(fullscreen_vertex_body()); }
std::string resolve_fragment(const GlApi& gl) { return glsl_preamble(gl) + kResolveFragment; }
std::string reduce_fragment(const GlApi& gl) { return glsl_preamble(gl) + kReduceFragment; }

}  // namespace hdrd::shading::shaders

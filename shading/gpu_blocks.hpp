// C++ twins of the std140 uniform blocks in shading/shaders.cpp. The static_asserts pin
// every offset to the GLSL declaration (std140: vec4 = 16 bytes, mat4 = 64, arrays of
// structs padded to 16); change both together.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace hdrd::shading::gpu {

using vec4 = std::array<float, 4>;
using ivec4 = std::array<std::int32_t, 4>;
using mat4 = std::array<float, 16>;  // column-major

inline constexpr int kMaxLights = 64;  // = SceneLimits::max_lights and the GLSL array size

// layout(std140, binding = 0) uniform Frame
struct FrameBlock {
  mat4 view_proj;      // world -> camera clip
  mat4 light_clip;     // world -> shadow-map clip (orthographic)
  mat4 inv_view_proj;  // camera clip -> world (the background's view rays)
  mat4 env_rotation;   // world -> environment directions (3x3 in a mat4)
  vec4 camera_pos;     // xyz
  vec4 ambient_nits;   // rgb radiance; w = 1 when the scene has an ambient term
  vec4 params;         // x pre-exposure, y medium IOR, z light count, w 1 = shadow map bound
  vec4 shadow_params;  // x normal offset (m), y 1/shadow-map size, z output clamp, w unused
  vec4 env_params;     // x radiance scale, y specular max LOD, z kEnv* mode, w background LOD
  vec4 sun_disc;       // xyz world direction toward the sun, w cos of its angular radius
  vec4 sun_radiance;   // rgb disc radiance (scaled), w 1 = the background shows the disc
  vec4 options;        // x 1 = multiple-scattering energy compensation
};
static_assert(offsetof(FrameBlock, light_clip) == 64);
static_assert(offsetof(FrameBlock, inv_view_proj) == 128);
static_assert(offsetof(FrameBlock, env_rotation) == 192);
static_assert(offsetof(FrameBlock, camera_pos) == 256);
static_assert(offsetof(FrameBlock, ambient_nits) == 272);
static_assert(offsetof(FrameBlock, params) == 288);
static_assert(offsetof(FrameBlock, shadow_params) == 304);
static_assert(offsetof(FrameBlock, env_params) == 320);
static_assert(offsetof(FrameBlock, sun_disc) == 336);
static_assert(offsetof(FrameBlock, sun_radiance) == 352);
static_assert(offsetof(FrameBlock, options) == 368);
static_assert(sizeof(FrameBlock) == 384);

// env_params.z: where environment light comes from.
inline constexpr int kEnvNone = 0, kEnvUniform = 1, kEnvMap = 2;

// struct Light in layout(std140, binding = 1) uniform Lights { Light lights[kMaxLights]; }
struct LightEntry {
  vec4 color_intensity;  // rgb = colour * (lux for directional, candela otherwise)
  vec4 position_type;    // xyz position; w 0 directional, 1 point, 2 spot
  vec4 direction_range;  // xyz unit travel direction; w range in m (0 = infinite)
  vec4 spot;             // x cone scale, y cone offset (glTF), z 1 = uses the shadow map
};
static_assert(sizeof(LightEntry) == 64);
struct LightBlock {
  std::array<LightEntry, kMaxLights> lights;
};
static_assert(sizeof(LightBlock) == 64 * kMaxLights);

// layout(std140, binding = 2) uniform Draw, one per instance (bound with a range).
struct DrawBlock {
  mat4 model;
  mat4 normal_matrix;  // inverse-transpose of the model's 3x3, in a mat4
  vec4 base_color;     // rgb + alpha
  vec4 emissive_nits;  // rgb
  vec4 surface;        // x metallic, y roughness, z dielectric F0 (for the medium), w F90
  vec4 extra;          // x Fresnel exponent, y normal scale, z occlusion strength, w ambient visibility
  vec4 metal_n;        // xyz real IOR of the metal, w alpha cutoff
  ivec4 flags;         // x texture bits (kTex*), y alpha mode (0/1/2), z double-sided, w handedness (+-1)
};
static_assert(offsetof(DrawBlock, normal_matrix) == 64);
static_assert(offsetof(DrawBlock, base_color) == 128);
static_assert(offsetof(DrawBlock, emissive_nits) == 144);
static_assert(offsetof(DrawBlock, surface) == 160);
static_assert(offsetof(DrawBlock, extra) == 176);
static_assert(offsetof(DrawBlock, metal_n) == 192);
static_assert(offsetof(DrawBlock, flags) == 208);
static_assert(sizeof(DrawBlock) == 224);

inline constexpr int kTexBaseColor = 1, kTexMetalRough = 2, kTexNormal = 4, kTexEmissive = 8, kTexOcclusion = 16;

// Texture units the lit program samples (layout(binding = N) in GLSL).
enum TextureUnit : int {
  kUnitBaseColor = 0,
  kUnitMetalRough = 1,
  kUnitNormal = 2,
  kUnitEmissive = 3,
  kUnitOcclusion = 4,
  kUnitShadow = 5,
  kUnitAmbientLut = 6,
  kUnitEnvSpecular = 7,    // prefiltered GGX cube map (roughness = LOD / max LOD)
  kUnitEnvIrradiance = 8,  // irradiance cube map, lux
  kUnitEnvBackground = 9,  // the equirectangular map itself (background pass)
};

inline constexpr int kAmbientLutSize = 32;  // n.v x roughness

}  // namespace hdrd::shading::gpu

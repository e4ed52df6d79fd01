// The renderer's scene description, whatever it was loaded from (built-in, JSON, glTF).
// Units: metres, lux (directional lights), candela (point and spot lights), cd/m2
// (emission, ambient and background radiance). Colours are linear Rec.709.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "encode/result.hpp"
#include "shading/environment.hpp"
#include "shading/math.hpp"

namespace hdrd::shading {

struct SceneAnimation;  // animation.hpp

struct Vertex {
  std::array<float, 3> position{};
  std::array<float, 3> normal{0, 0, 1};
  std::array<float, 4> tangent{1, 0, 0, 1};  // xyz + handedness w (glTF)
  std::array<float, 2> uv{};
};
static_assert(sizeof(Vertex) == 12 * sizeof(float), "Vertex is uploaded as 12 packed floats");

// One triangle-list primitive.
struct Mesh {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
};

enum class Wrap { repeat, clamp, mirror };

// An 8-bit RGBA image. Whether it holds sRGB-encoded colour is decided by its use
// (glTF: base colour and emissive are sRGB, the rest linear), not here.
struct Texture {
  std::string name;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba8;
  Wrap wrap_s = Wrap::repeat, wrap_t = Wrap::repeat;
  bool linear_filter = true;
  bool mipmaps = true;
};

enum class AlphaMode { opaque, mask, blend };

struct TextureRef {
  int index = -1;  // into Scene::textures; -1: none
  double scale = 1.0;  // normalTexture.scale / occlusionTexture.strength
  explicit operator bool() const { return index >= 0; }
};

struct Material {
  std::string name;
  Vec3 base_color{1, 1, 1};
  double alpha = 1.0;
  double metallic = 0.0;
  double roughness = 0.5;
  double dielectric_f0 = 0.04;      // in air (glTF's IOR 1.5); converted for the medium (eq. 9.19)
  Vec3 metal_n{1, 1, 1};            // real IOR of the metal part (materials.hpp), for other media
  double f90 = 1.0;
  double fresnel_exponent = 5.0;    // eq. 9.18's 1/p
  Vec3 emissive_nits{0, 0, 0};      // cd/m2, times the emissive texture
  double ambient_visibility = 1.0;  // fraction of the ambient term that reaches the surface
  AlphaMode alpha_mode = AlphaMode::opaque;
  double alpha_cutoff = 0.5;
  bool double_sided = false;
  TextureRef base_color_texture, metallic_roughness_texture, normal_texture, emissive_texture,
      occlusion_texture;
};

struct Instance {
  int mesh = 0;
  int material = 0;
  Mat4 transform;
};

enum class LightType { directional, point, spot };

struct Light {
  std::string name;
  LightType type = LightType::directional;
  Vec3 color{1, 1, 1};
  double illuminance_lux = 0;  // directional: at normal incidence
  double intensity_cd = 0;     // point and spot
  Vec3 position{0, 0, 0};
  Vec3 direction{0, -1, 0};    // where the light travels (from the light into the scene)
  double range_m = 0;          // 0 = infinite; else a smooth window to zero at range
  double inner_cone_rad = 0;
  double outer_cone_rad = kPi / 4;
  bool cast_shadows = true;    // honoured for the brightest directional light
};

struct Camera {
  Vec3 position{0, 0, 5};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  double yfov_rad = 45.0 * kPi / 180.0;
  double znear_m = 0;  // 0: fitted to the scene bounds
  double zfar_m = 0;
};

struct Scene {
  std::string name;
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::optional<Camera> camera;
  std::optional<Vec3> ambient_nits;     // uniform environment radiance; only when asked for
  // Light from the world: an environment map or the built-in sky (with its sun). Exclusive
  // with ambient_nits; the renderer adds the sky's sun to the lights.
  std::optional<EnvironmentSpec> environment;
  std::optional<Vec3> background_nits;  // what the camera sees behind everything (default: environment, ambient or 0)
  double medium_ior = 1.0;              // 1 = air, 1.33 = water
  std::vector<std::string> warnings;
  // Keyframes (glTF animations, JSON keyframes, a built-in's motion); none: a still scene.
  // The scene as stored is the rest pose; animate() (animation.hpp) poses it at a time.
  std::shared_ptr<const SceneAnimation> animation;
};

struct SceneLimits {
  int max_lights = 64;
  std::int64_t max_triangles = 8'000'000;
  int max_instances = 100'000;
  int max_materials = 10'000;
  int max_textures = 1'024;
  std::int64_t max_texture_bytes = 1LL << 30;
};

struct Bounds {
  Vec3 min{0, 0, 0}, max{0, 0, 0};
  bool empty = true;
  Vec3 center() const { return (min + max) * 0.5; }
  double radius() const { return empty ? 0.0 : length(max - min) * 0.5; }
};
Bounds world_bounds(const Scene& s);

// Checks references, counts, finiteness and degenerate geometry. Degenerate triangles
// are dropped with a warning; a mesh with no triangle left is an error.
Result<void> validate(Scene& s, const SceneLimits& limits = {});

Result<void> validate_camera(const Camera& c);

// A camera looking at the scene's bounds from the front, slightly above.
Camera default_camera(const Scene& s, double aspect);

// The environment's light as the meter sees it in one frame (rotation and scale applied).
struct MeteredEnvironment {
  const IrradianceCube* irradiance = nullptr;  // none: no environment map
  Mat4 world_to_environment;
  double scale = 1;
};

// Largest illuminance on a card at the camera's subject (its target), in lux, for
// light-based exposure (REFERENCE.md §1.2): the card turned toward each light receives
// that light (directional E, point/spot I/d^2) plus what the environment gives on it
// (the irradiance map, or pi L for an ambient radiance L); turned toward the brightest
// part of the environment it receives the environment's largest irradiance. 0 when the
// scene has no light at all.
double dominant_illuminance_lux(const Scene& s, const Camera& camera, const MeteredEnvironment& environment = {});

}  // namespace hdrd::shading

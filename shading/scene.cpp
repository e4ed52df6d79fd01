#include "shading/scene.hpp"

#include <fmt/format.h>

#include "shading/shapes.hpp"

namespace hdrd::shading {
namespace {

Vec3 v3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

bool finite_nonneg(Vec3 v) { return is_finite(v) && v.x >= 0 && v.y >= 0 && v.z >= 0; }
bool in_unit(double x) { return std::isfinite(x) && x >= 0 && x <= 1; }

Error scene_error(std::string field, std::string what) {
  std::string msg = fmt::format("{}: {}", field, what);
  return make_error("scene.invalid", std::move(msg), std::move(field));
}

Result<void> validate_light(const Light& l, std::size_t i) {
  const std::string f = fmt::format("lights[{}]", i);
  if (!finite_nonneg(l.color)) return scene_error(f + ".color", "must be finite and >= 0");
  if (!std::isfinite(l.illuminance_lux) || l.illuminance_lux < 0)
    return scene_error(f + ".illuminance_lux", "must be finite and >= 0");
  if (!std::isfinite(l.intensity_cd) || l.intensity_cd < 0)
    return scene_error(f + ".intensity_cd", "must be finite and >= 0");
  if (!is_finite(l.position)) return scene_error(f + ".position", "must be finite");
  if (!is_finite(l.direction) || length(l.direction) < 1e-12)
    return scene_error(f + ".direction", "must be a finite non-zero vector");
  if (!std::isfinite(l.range_m) || l.range_m < 0) return scene_error(f + ".range_m", "must be finite and >= 0");
  if (l.type == LightType::spot &&
      !(l.inner_cone_rad >= 0 && l.inner_cone_rad < l.outer_cone_rad && l.outer_cone_rad <= kPi / 2))
    return scene_error(f + ".outer_cone", "needs 0 <= inner < outer <= 90 degrees");
  return {};
}

Result<void> validate_material(const Material& m, std::size_t i, std::size_t texture_count) {
  const std::string f = fmt::format("materials[{}]", i);
  if (!is_finite(m.base_color) || !in_unit(m.base_color.x) || !in_unit(m.base_color.y) || !in_unit(m.base_color.z))
    return scene_error(f + ".base_color", "components must be in [0, 1]");
  const std::pair<const char*, double> unit[] = {{"alpha", m.alpha}, {"metallic", m.metallic},
                                                 {"roughness", m.roughness}, {"f0", m.dielectric_f0},
                                                 {"f90", m.f90}, {"alpha_cutoff", m.alpha_cutoff},
                                                 {"ambient_visibility", m.ambient_visibility}};
  for (const auto& [name, v] : unit)
    if (!in_unit(v)) return scene_error(f + "." + name, "must be in [0, 1]");
  if (!std::isfinite(m.fresnel_exponent) || m.fresnel_exponent <= 0 || m.fresnel_exponent > 64)
    return scene_error(f + ".fresnel_power", "must be in (0, 64]");
  if (!finite_nonneg(m.emissive_nits)) return scene_error(f + ".emissive_nits", "must be finite and >= 0");
  if (!is_finite(m.metal_n) || m.metal_n.x <= 0 || m.metal_n.y <= 0 || m.metal_n.z <= 0)
    return scene_error(f + ".metal_n", "must be finite and > 0");
  for (const TextureRef* t : {&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture,
                              &m.emissive_texture, &m.occlusion_texture}) {
    if (t->index >= static_cast<int>(texture_count)) return scene_error(f, "refers to a missing texture");
    if (!std::isfinite(t->scale)) return scene_error(f, "texture scale must be finite");
  }
  return {};
}

// Drops zero-area triangles (warning), rejects out-of-range indices and NaN attributes.
Result<void> validate_mesh(Mesh& m, std::size_t i, std::vector<std::string>& warnings, std::int64_t& dropped) {
  const std::string f = fmt::format("meshes[{}]", i);
  const auto mesh_error = [&](const std::string& what) {
    return make_error("scene.invalid", fmt::format("{} '{}': {}", f, m.name, what), f);
  };
  if (m.indices.size() % 3 != 0) return mesh_error("index count is not a multiple of 3");
  bool bad_normal = false;
  for (const Vertex& v : m.vertices) {
    for (float x : v.position) if (!std::isfinite(x)) return mesh_error("has a non-finite position");
    for (float x : v.uv) if (!std::isfinite(x)) return mesh_error("has a non-finite texture coordinate");
    const Vec3 n = v3(v.normal);
    if (!is_finite(n) || length(n) < 1e-12) bad_normal = true;
  }
  std::vector<std::uint32_t> kept;
  kept.reserve(m.indices.size());
  for (std::size_t t = 0; t < m.indices.size(); t += 3) {
    const std::uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
    if (a >= m.vertices.size() || b >= m.vertices.size() || c >= m.vertices.size())
      return mesh_error(fmt::format("index {} is out of range ({} vertices)", std::max({a, b, c}), m.vertices.size()));
    const Vec3 pa = v3(m.vertices[a].position);
    if (length(cross(v3(m.vertices[b].position) - pa, v3(m.vertices[c].position) - pa)) <= 0) continue;
    kept.insert(kept.end(), {a, b, c});
  }
  if (kept.empty()) return mesh_error("has no non-degenerate triangle");
  dropped += static_cast<std::int64_t>((m.indices.size() - kept.size()) / 3);
  m.indices = std::move(kept);
  if (bad_normal) {
    warnings.push_back(fmt::format("{} '{}': missing or zero normals recomputed from the triangles", f, m.name));
    compute_normals(m);
  }
  return {};
}

Result<void> validate_counts(const Scene& s, const SceneLimits& limits) {
  if (static_cast<int>(s.lights.size()) > limits.max_lights)
    return scene_error("lights", fmt::format("{} lights exceed the limit of {}", s.lights.size(), limits.max_lights));
  if (static_cast<int>(s.materials.size()) > limits.max_materials)
    return scene_error("materials", fmt::format("{} materials exceed the limit of {}", s.materials.size(),
                                                limits.max_materials));
  if (static_cast<int>(s.instances.size()) > limits.max_instances)
    return scene_error("objects", fmt::format("{} objects exceed the limit of {}", s.instances.size(),
                                              limits.max_instances));
  if (static_cast<int>(s.textures.size()) > limits.max_textures)
    return scene_error("textures", fmt::format("{} textures exceed the limit of {}", s.textures.size(),
                                               limits.max_textures));
  std::int64_t bytes = 0;
  for (std::size_t i = 0; i < s.textures.size(); ++i) {
    const Texture& t = s.textures[i];
    if (t.width <= 0 || t.height <= 0 || t.width > 16384 || t.height > 16384 ||
        t.rgba8.size() != static_cast<std::size_t>(t.width) * t.height * 4)
      return scene_error(fmt::format("textures[{}]", i), fmt::format("bad size {}x{}", t.width, t.height));
    bytes += static_cast<std::int64_t>(t.rgba8.size());
  }
  if (bytes > limits.max_texture_bytes)
    return scene_error("textures", fmt::format("{} MiB of textures exceed the limit of {} MiB", bytes >> 20,
                                               limits.max_texture_bytes >> 20));
  return {};
}

Result<void> validate_environment(const Scene& s) {
  if (!std::isfinite(s.medium_ior) || s.medium_ior < 1.0 || s.medium_ior > 3.0)
    return scene_error("medium_ior", "must be in [1, 3]");
  if (s.ambient_nits && !finite_nonneg(*s.ambient_nits)) return scene_error("ambient", "must be finite and >= 0");
  if (s.environment) {
    if (s.ambient_nits) return scene_error("ambient_nits", "give either ambient_nits or environment, not both");
    if (auto r = validate_environment_spec(*s.environment); !r) return r;
  }
  if (s.background_nits && !finite_nonneg(*s.background_nits))
    return scene_error("background_nits", "must be finite and >= 0");
  if (s.camera) return validate_camera(*s.camera);
  return {};
}

}  // namespace

Result<void> validate_camera(const Camera& c) {
  if (!is_finite(c.position) || !is_finite(c.target) || !is_finite(c.up))
    return scene_error("camera", "position, target and up must be finite");
  if (length(c.target - c.position) < 1e-9) return scene_error("camera.target", "equals the camera position");
  if (!(c.yfov_rad > 0 && c.yfov_rad < kPi)) return scene_error("camera.yfov_deg", "must be in (0, 180)");
  if (!std::isfinite(c.znear_m) || !std::isfinite(c.zfar_m) || c.znear_m < 0 ||
      (c.zfar_m != 0 && c.zfar_m <= c.znear_m))
    return scene_error("camera.znear_m", "needs 0 <= znear < zfar");
  return {};
}

Bounds world_bounds(const Scene& s) {
  Bounds b;
  for (const Instance& inst : s.instances) {
    if (inst.mesh < 0 || inst.mesh >= static_cast<int>(s.meshes.size())) continue;
    for (const Vertex& v : s.meshes[inst.mesh].vertices) {
      const Vec3 p = inst.transform.transform_point(v3(v.position));
      if (!is_finite(p)) continue;
      b.min = b.empty ? p : vmin(b.min, p);
      b.max = b.empty ? p : vmax(b.max, p);
      b.empty = false;
    }
  }
  return b;
}

Result<void> validate(Scene& s, const SceneLimits& limits) {
  if (auto r = validate_counts(s, limits); !r) return r;
  if (auto r = validate_environment(s); !r) return r;
  for (std::size_t i = 0; i < s.lights.size(); ++i)
    if (auto r = validate_light(s.lights[i], i); !r) return r;
  for (std::size_t i = 0; i < s.materials.size(); ++i)
    if (auto r = validate_material(s.materials[i], i, s.textures.size()); !r) return r;
  std::int64_t dropped = 0;
  for (std::size_t i = 0; i < s.meshes.size(); ++i)
    if (auto r = validate_mesh(s.meshes[i], i, s.warnings, dropped); !r) return r;
  if (dropped > 0) s.warnings.push_back(fmt::format("dropped {} zero-area triangles", dropped));
  std::int64_t triangles = 0;
  for (std::size_t i = 0; i < s.instances.size(); ++i) {
    const Instance& inst = s.instances[i];
    const std::string f = fmt::format("objects[{}]", i);
    if (inst.mesh < 0 || inst.mesh >= static_cast<int>(s.meshes.size()))
      return scene_error(f, "refers to a missing mesh");
    if (inst.material < 0 || inst.material >= static_cast<int>(s.materials.size()))
      return scene_error(f, "refers to a missing material");
    const double det = determinant(inst.transform);
    if (!is_finite(inst.transform) || !std::isfinite(det) || std::abs(det) < 1e-18)
      return scene_error(f + ".transform", "must be finite and invertible");
    triangles += static_cast<std::int64_t>(s.meshes[inst.mesh].indices.size() / 3);
  }
  if (triangles > limits.max_triangles)
    return scene_error("objects", fmt::format("{} triangles exceed the limit of {}", triangles, limits.max_triangles));
  return {};
}

Camera default_camera(const Scene& s, double aspect) {
  const Bounds b = world_bounds(s);
  Camera c;
  if (b.empty) return c;
  const Vec3 center = b.center();
  const double radius = std::max(b.radius(), 1e-3);
  const double half_fov = std::min(c.yfov_rad, 2 * std::atan(std::tan(c.yfov_rad / 2) * aspect)) / 2;
  const double distance = radius / std::sin(half_fov) * 1.05;
  const Vec3 dir = normalize(Vec3{0, 0.25, 1});
  c.position = center + dir * distance;
  c.target = center;
  return c;
}

double dominant_illuminance_lux(const Scene& s, const Camera& camera, const MeteredEnvironment& env) {
  // Irradiance from the environment on a card facing `n`, and the largest over all n.
  const auto environment_lux = [&](Vec3 n) {
    if (s.ambient_nits) return kPi * luminance(*s.ambient_nits);
    if (!env.irradiance) return 0.0;
    return env.scale * luminance(env.irradiance->lookup(env.world_to_environment.transform_dir(n)));
  };
  double best = s.ambient_nits ? kPi * luminance(*s.ambient_nits)
                               : env.irradiance ? env.scale * env.irradiance->max_illuminance_lux() : 0.0;
  for (const Light& l : s.lights) {
    double e = 0;
    Vec3 toward{0, 1, 0};
    if (l.type == LightType::directional) {
      e = l.illuminance_lux;
      toward = -normalize(l.direction);
    } else {
      const Vec3 d = l.position - camera.target;
      e = l.intensity_cd / std::max(dot(d, d), 1e-6);
      toward = normalize(d);
    }
    const double lux = e * luminance(l.color);
    if (lux > 0) best = std::max(best, lux + environment_lux(toward));
  }
  return best;
}

}  // namespace hdrd::shading

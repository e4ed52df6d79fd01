// The hdrd JSON scene format (docs/scene-format.md). Strict: every problem is an error
// naming its field, and nothing is allocated from a count before the count is checked.
#include <algorithm>
#include <map>
#include <set>

#include <fmt/format.h>

#include "encode/io/json_text.hpp"
#include "shading/animation.hpp"
#include "shading/gltf_internal.hpp"
#include "shading/materials.hpp"
#include "shading/scene_loader.hpp"
#include "shading/shapes.hpp"

namespace hdrd::shading {
namespace {

using nlohmann::json;

constexpr int kFormatVersion = 1;
constexpr std::size_t kMaxMeshVertices = 4'000'000;
// The format nests five levels (objects[i].mesh.positions[j]); 64 leaves room for any
// reasonable document and none for one built to exhaust the stack.
constexpr int kMaxSceneJsonDepth = 64;

// Reads fields with a sticky first error: after a failure every read returns its
// default, and the caller checks failed() once per object.
class Reader {
 public:
  bool failed() const { return error_.has_value(); }
  Error error() const { return *error_; }
  void fail(const std::string& field, const std::string& what) {
    if (!error_) error_ = make_error("scene.json", fmt::format("{}: {}", field, what), field);
  }

  // The object itself, and that it has no keys outside `allowed`.
  bool object(const json& j, const std::string& path, const std::vector<std::string_view>& allowed) {
    if (failed()) return false;
    if (!j.is_object()) {
      fail(path.empty() ? "scene" : path, "must be an object");
      return false;
    }
    const std::set<std::string_view> ok(allowed.begin(), allowed.end());
    for (const auto& [k, v] : j.items())
      if (!ok.count(k)) {
        fail(join(path, k), "unknown field");
        return false;
      }
    return true;
  }

  double number(const json& o, const std::string& path, const char* key, double fallback, double lo, double hi) {
    const json* v = find(o, key);
    if (!v || failed()) return fallback;
    if (!v->is_number()) return fail(join(path, key), "must be a number"), fallback;
    const double x = v->get<double>();
    if (!std::isfinite(x)) return fail(join(path, key), "must be finite"), fallback;
    if (x < lo || x > hi) return fail(join(path, key), fmt::format("{} is outside [{}, {}]", x, lo, hi)), fallback;
    return x;
  }
  std::optional<double> opt_number(const json& o, const std::string& path, const char* key, double lo, double hi) {
    if (!find(o, key)) return std::nullopt;
    return number(o, path, key, 0, lo, hi);
  }

  // [x, y, z], or a single number meaning (x, x, x) when `scalar_ok`.
  std::optional<Vec3> opt_vec3(const json& o, const std::string& path, const char* key, double lo, double hi,
                               bool scalar_ok = false) {
    const json* v = find(o, key);
    if (!v || failed()) return std::nullopt;
    if (scalar_ok && v->is_number()) {
      const double x = number(o, path, key, 0, lo, hi);
      return Vec3{x, x, x};
    }
    if (!v->is_array() || v->size() != 3)
      return fail(join(path, key), scalar_ok ? "must be [x, y, z] or a number" : "must be [x, y, z]"), std::nullopt;
    double c[3];
    for (int i = 0; i < 3; ++i) {
      const json& e = (*v)[i];
      const std::string f = fmt::format("{}[{}]", join(path, key), i);
      if (!e.is_number()) return fail(f, "must be a number"), std::nullopt;
      c[i] = e.get<double>();
      if (!std::isfinite(c[i])) return fail(f, "must be finite"), std::nullopt;
      if (c[i] < lo || c[i] > hi) return fail(f, fmt::format("{} is outside [{}, {}]", c[i], lo, hi)), std::nullopt;
    }
    return Vec3{c[0], c[1], c[2]};
  }
  Vec3 vec3(const json& o, const std::string& path, const char* key, Vec3 fallback, double lo, double hi,
            bool scalar_ok = false) {
    return opt_vec3(o, path, key, lo, hi, scalar_ok).value_or(fallback);
  }

  std::string string(const json& o, const std::string& path, const char* key, std::string fallback) {
    const json* v = find(o, key);
    if (!v || failed()) return fallback;
    if (!v->is_string()) return fail(join(path, key), "must be a string"), fallback;
    return v->get<std::string>();
  }
  bool boolean(const json& o, const std::string& path, const char* key, bool fallback) {
    const json* v = find(o, key);
    if (!v || failed()) return fallback;
    if (!v->is_boolean()) return fail(join(path, key), "must be true or false"), fallback;
    return v->get<bool>();
  }
  // An array of at most `max` entries (absent: empty).
  const json* array(const json& o, const std::string& path, const char* key, std::size_t max) {
    const json* v = find(o, key);
    if (!v || failed()) return nullptr;
    if (!v->is_array()) return fail(join(path, key), "must be an array"), nullptr;
    if (v->size() > max) return fail(join(path, key), fmt::format("{} entries exceed the limit of {}", v->size(), max)), nullptr;
    return v;
  }

  static std::string join(const std::string& path, std::string_view key) {
    return path.empty() ? std::string(key) : fmt::format("{}.{}", path, key);
  }

 private:
  static const json* find(const json& o, const char* key) {
    const auto it = o.find(key);
    return it == o.end() ? nullptr : &*it;
  }
  std::optional<Error> error_;
};

constexpr double kBig = 1e9;  // metres, lux, candela, cd/m2: anything beyond is a mistake

void read_camera(Reader& r, const json& j, Scene& s) {
  const std::string p = "camera";
  if (!r.object(j, p, {"position", "target", "up", "yfov_deg", "znear_m", "zfar_m"})) return;
  Camera c;
  c.position = r.vec3(j, p, "position", c.position, -kBig, kBig);
  c.target = r.vec3(j, p, "target", c.target, -kBig, kBig);
  c.up = r.vec3(j, p, "up", c.up, -kBig, kBig);
  c.yfov_rad = r.number(j, p, "yfov_deg", 45, 0.01, 179.9) * kPi / 180;
  c.znear_m = r.number(j, p, "znear_m", 0, 0, kBig);
  c.zfar_m = r.number(j, p, "zfar_m", 0, 0, kBig);
  if (!r.failed() && length(c.target - c.position) < 1e-9) r.fail("camera.target", "equals camera.position");
  s.camera = c;
}

Material read_material(Reader& r, const json& j, const std::string& p) {
  Material m;
  if (!r.object(j, p, {"name", "preset", "base_color", "alpha", "metallic", "roughness", "f0", "specular", "f90",
                       "fresnel_power", "emissive_nits", "double_sided", "ambient_visibility", "alpha_mode",
                       "alpha_cutoff", "metal_ior"}))
    return m;
  m.name = r.string(j, p, "name", "");
  const std::string preset = r.string(j, p, "preset", "");
  if (!preset.empty()) {
    const F0Preset* f = find_f0_preset(preset);
    if (!f) {
      r.fail(p + ".preset", fmt::format("unknown preset '{}' (see docs/scene-format.md)", preset));
      return m;
    }
    if (f->kind == PresetKind::metal) {
      m.metallic = 1;
      m.base_color = f->f0_air;
      m.metal_n = preset_metal_n(*f);
    } else {
      m.dielectric_f0 = f->f0_air.x;
    }
    if (m.name.empty()) m.name = preset;
  }
  m.base_color = r.vec3(j, p, "base_color", m.base_color, 0, 1, true);
  m.alpha = r.number(j, p, "alpha", 1, 0, 1);
  m.metallic = r.number(j, p, "metallic", m.metallic, 0, 1);
  m.roughness = r.number(j, p, "roughness", m.roughness, 0, 1);
  if (j.contains("f0") && j.contains("specular")) r.fail(p + ".specular", "give either f0 or specular, not both");
  m.dielectric_f0 = r.number(j, p, "f0", m.dielectric_f0, 0, 1);
  if (auto sp = r.opt_number(j, p, "specular", 0, 2.5)) m.dielectric_f0 = f0_from_specular(*sp);
  m.f90 = r.number(j, p, "f90", 1, 0, 1);
  m.fresnel_exponent = r.number(j, p, "fresnel_power", 5, 0.01, 64);
  m.emissive_nits = r.vec3(j, p, "emissive_nits", {0, 0, 0}, 0, kBig, true);
  m.double_sided = r.boolean(j, p, "double_sided", false);
  m.ambient_visibility = r.number(j, p, "ambient_visibility", 1, 0, 1);
  m.metal_n = r.vec3(j, p, "metal_ior", m.metal_n, 0.01, 20, true);
  const std::string mode = r.string(j, p, "alpha_mode", "opaque");
  if (mode == "mask") m.alpha_mode = AlphaMode::mask;
  else if (mode == "blend") m.alpha_mode = AlphaMode::blend;
  else if (mode != "opaque") r.fail(p + ".alpha_mode", "must be opaque, mask or blend");
  m.alpha_cutoff = r.number(j, p, "alpha_cutoff", 0.5, 0, 1);
  return m;
}

Light read_light(Reader& r, const json& j, const std::string& p) {
  Light l;
  if (!j.is_object()) return r.fail(p, "must be an object"), l;
  const std::string type = r.string(j, p, "type", "");
  if (type == "directional") {
    if (!r.object(j, p, {"type", "name", "direction", "illuminance_lux", "color", "cast_shadows"})) return l;
    l.type = LightType::directional;
    l.illuminance_lux = r.number(j, p, "illuminance_lux", 0, 0, kBig);
    l.cast_shadows = r.boolean(j, p, "cast_shadows", true);
  } else if (type == "point" || type == "spot") {
    if (type == "point" && !r.object(j, p, {"type", "name", "position", "intensity_cd", "range_m", "color"})) return l;
    if (type == "spot" && !r.object(j, p, {"type", "name", "position", "direction", "intensity_cd", "range_m",
                                           "color", "inner_cone_deg", "outer_cone_deg"}))
      return l;
    l.type = type == "point" ? LightType::point : LightType::spot;
    l.position = r.vec3(j, p, "position", {0, 0, 0}, -kBig, kBig);
    l.intensity_cd = r.number(j, p, "intensity_cd", 0, 0, kBig);
    l.range_m = r.number(j, p, "range_m", 0, 0, kBig);
    l.inner_cone_rad = r.number(j, p, "inner_cone_deg", 0, 0, 90) * kPi / 180;
    l.outer_cone_rad = r.number(j, p, "outer_cone_deg", 45, 0, 90) * kPi / 180;
    if (!r.failed() && l.type == LightType::spot && !(l.inner_cone_rad < l.outer_cone_rad))
      r.fail(p + ".inner_cone_deg", "must be smaller than outer_cone_deg");
  } else {
    r.fail(p + ".type", "must be directional, point or spot");
    return l;
  }
  l.name = r.string(j, p, "name", "");
  l.color = r.vec3(j, p, "color", {1, 1, 1}, 0, kBig, true);
  l.direction = r.vec3(j, p, "direction", l.direction, -kBig, kBig);
  if (!r.failed() && length(l.direction) < 1e-12) r.fail(p + ".direction", "must not be zero");
  return l;
}

Mat4 read_transform(Reader& r, const json& j, const std::string& p) {
  const Vec3 pos = r.vec3(j, p, "position", {0, 0, 0}, -kBig, kBig);
  const Vec3 rot = r.vec3(j, p, "rotation_deg", {0, 0, 0}, -3600, 3600);
  const Vec3 scl = r.vec3(j, p, "scale", {1, 1, 1}, -1e6, 1e6, true);
  if (!r.failed() && std::abs(scl.x * scl.y * scl.z) < 1e-18) r.fail(p + ".scale", "must not be zero");
  return translate(pos) * rotate_xyz_deg(rot) * scale(scl);
}

// "material": a name or an index into materials[].
int read_material_ref(Reader& r, const json& j, const std::string& p, const Scene& s,
                      const std::map<std::string, int>& names) {
  const auto it = j.find("material");
  if (it == j.end()) return r.fail(p + ".material", "missing"), 0;
  if (it->is_string()) {
    const auto n = names.find(it->get<std::string>());
    if (n == names.end()) return r.fail(p + ".material", fmt::format("no material named '{}'", it->get<std::string>())), 0;
    return n->second;
  }
  if (it->is_number_integer() && it->get<std::int64_t>() >= 0 &&
      it->get<std::int64_t>() < static_cast<std::int64_t>(s.materials.size()))
    return static_cast<int>(it->get<std::int64_t>());
  return r.fail(p + ".material", "must be a material name or index"), 0;
}

// A flat number array of at most `max` entries, a multiple of `group`.
std::vector<double> read_flat(Reader& r, const json& j, const std::string& p, const char* key, std::size_t group,
                              std::size_t max, bool integers) {
  std::vector<double> out;
  const json* a = r.array(j, p, key, max);
  if (!a) return out;
  if (a->size() % group != 0) return r.fail(Reader::join(p, key), fmt::format("length must be a multiple of {}", group)), out;
  out.reserve(a->size());
  for (std::size_t i = 0; i < a->size(); ++i) {
    const json& e = (*a)[i];
    const bool ok = integers ? (e.is_number_unsigned() || (e.is_number_integer() && e.get<std::int64_t>() >= 0))
                             : e.is_number();
    if (!ok || !std::isfinite(e.get<double>()))
      return r.fail(fmt::format("{}[{}]", Reader::join(p, key), i),
                    integers ? "must be a non-negative integer" : "must be a finite number"), out;
    out.push_back(e.get<double>());
  }
  return out;
}

Mesh read_mesh(Reader& r, const json& j, const std::string& p) {
  Mesh m;
  m.name = r.string(j, p, "name", "mesh");
  const auto pos = read_flat(r, j, p, "positions", 3, 3 * kMaxMeshVertices, false);
  const auto nrm = read_flat(r, j, p, "normals", 3, 3 * kMaxMeshVertices, false);
  const auto uvs = read_flat(r, j, p, "uvs", 2, 2 * kMaxMeshVertices, false);
  const auto idx = read_flat(r, j, p, "indices", 3, 3 * kMaxMeshVertices * 4, true);
  if (r.failed()) return m;
  const std::size_t n = pos.size() / 3;
  if (n < 3) return r.fail(p + ".positions", "needs at least 3 vertices"), m;
  if (!nrm.empty() && nrm.size() != pos.size()) return r.fail(p + ".normals", "must match positions"), m;
  if (!uvs.empty() && uvs.size() / 2 != n) return r.fail(p + ".uvs", "must have one pair per vertex"), m;
  if (idx.empty() && n % 3 != 0) return r.fail(p + ".positions", "without indices, needs a multiple of 3 vertices"), m;
  m.vertices.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Vertex& v = m.vertices[i];
    v.position = {float(pos[3 * i]), float(pos[3 * i + 1]), float(pos[3 * i + 2])};
    if (!nrm.empty()) v.normal = {float(nrm[3 * i]), float(nrm[3 * i + 1]), float(nrm[3 * i + 2])};
    if (!uvs.empty()) v.uv = {float(uvs[2 * i]), float(uvs[2 * i + 1])};
  }
  for (std::size_t i = 0; i < (idx.empty() ? n : idx.size()); ++i) {
    const double k = idx.empty() ? double(i) : idx[i];
    if (k >= double(n)) return r.fail(fmt::format("{}.indices[{}]", p, i), fmt::format("{} >= vertex count {}", k, n)), m;
    m.indices.push_back(static_cast<std::uint32_t>(k));
  }
  if (nrm.empty()) compute_normals(m);
  compute_tangents(m);
  return m;
}

void read_shape(Reader& r, const json& j, const std::string& p, const std::string& type, Scene& s,
                std::int64_t& triangles, const SceneLoadOptions& options) {
  Mesh m;
  if (type == "sphere") {
    const double radius = r.number(j, p, "radius", 1, 1e-6, kBig);
    const int seg = static_cast<int>(r.number(j, p, "segments", 48, 3, kMaxSphereSegments));
    const int rings = static_cast<int>(r.number(j, p, "rings", std::max(2, seg / 2), 2, kMaxSphereSegments));
    triangles += 2LL * seg * rings;
    if (triangles > options.limits.max_triangles || r.failed()) return;
    m = make_sphere(radius, seg, rings);
  } else if (type == "plane") {
    const json* size = j.contains("size") ? &j["size"] : nullptr;
    if (size && !(size->is_array() && size->size() == 2 && (*size)[0].is_number() && (*size)[1].is_number()))
      return r.fail(p + ".size", "must be [size_x, size_z]");
    const double sx = size ? (*size)[0].get<double>() : 1, sz = size ? (*size)[1].get<double>() : 1;
    if (!(sx > 0 && sz > 0 && sx < kBig && sz < kBig)) return r.fail(p + ".size", "must be positive and finite");
    m = make_plane(sx, sz);
  } else if (type == "box") {
    const Vec3 size = r.vec3(j, p, "size", {1, 1, 1}, 1e-6, kBig, true);
    m = make_box(size);
  } else {
    m = read_mesh(r, j, p);
    triangles += static_cast<std::int64_t>(m.indices.size() / 3);
  }
  if (r.failed()) return;
  s.meshes.push_back(std::move(m));
}

// Appends `src` under `transform`: meshes, materials, textures and instances always,
// its lights and camera when asked.
void append_scene(Scene& dst, Scene src, const Mat4& transform, bool lights, bool camera) {
  const int mesh0 = static_cast<int>(dst.meshes.size()), mat0 = static_cast<int>(dst.materials.size());
  const int tex0 = static_cast<int>(dst.textures.size());
  for (auto& m : src.meshes) dst.meshes.push_back(std::move(m));
  for (auto& t : src.textures) dst.textures.push_back(std::move(t));
  for (Material m : src.materials) {
    for (TextureRef* t : {&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture,
                          &m.emissive_texture, &m.occlusion_texture})
      if (*t) t->index += tex0;
    dst.materials.push_back(std::move(m));
  }
  for (const Instance& i : src.instances) dst.instances.push_back({i.mesh + mesh0, i.material + mat0, transform * i.transform});
  if (lights)
    for (Light l : src.lights) {
      l.position = transform.transform_point(l.position);
      l.direction = normalize(transform.transform_dir(l.direction));
      dst.lights.push_back(l);
    }
  if (camera && src.camera && !dst.camera) {
    Camera c = *src.camera;
    c.position = transform.transform_point(c.position);
    c.target = transform.transform_point(c.target);
    c.up = normalize(transform.transform_dir(c.up));
    dst.camera = c;
  }
  for (auto& w : src.warnings) dst.warnings.push_back(std::move(w));
  if (src.animation)
    dst.warnings.push_back("the animations of an imported glTF file are not played (render the .gltf itself to animate it)");
}

void import_gltf_object(Reader& r, const json& j, const std::string& p, const Mat4& transform, Scene& s,
                        const SceneLoadOptions& options) {
  const std::string path = r.string(j, p, "path", "");
  const bool lights = r.boolean(j, p, "import_lights", true), camera = r.boolean(j, p, "import_camera", true);
  if (r.failed()) return;
  if (path.empty()) return r.fail(p + ".path", "missing");
  if (!options.allow_files) return r.fail(p + ".path", "file references are not allowed here");
  const std::filesystem::path file = std::filesystem::path(path).is_absolute() ? std::filesystem::path(path)
                                                                               : options.base_dir / path;
  auto g = load_gltf_raw(file, options);
  if (!g) return r.fail(p + ".path", g.error().message);
  append_scene(s, std::move(*g), transform, lights, camera);
  if (static_cast<int>(s.lights.size()) > options.limits.max_lights)
    r.fail(p + ".import_lights", fmt::format("more than {} lights in the scene", options.limits.max_lights));
}

void read_objects(Reader& r, const json& doc, Scene& s, const std::map<std::string, int>& names,
                  const SceneLoadOptions& options) {
  const json* objs = r.array(doc, "", "objects", static_cast<std::size_t>(options.limits.max_instances));
  if (!objs) return;
  std::int64_t triangles = 0;
  for (std::size_t i = 0; i < objs->size() && !r.failed(); ++i) {
    const json& j = (*objs)[i];
    const std::string p = fmt::format("objects[{}]", i);
    if (!j.is_object()) return r.fail(p, "must be an object");
    const std::string type = r.string(j, p, "type", "");
    static const std::map<std::string, std::vector<std::string_view>> kFields = {
        {"sphere", {"type", "name", "material", "position", "rotation_deg", "scale", "radius", "segments", "rings"}},
        {"plane", {"type", "name", "material", "position", "rotation_deg", "scale", "size"}},
        {"box", {"type", "name", "material", "position", "rotation_deg", "scale", "size"}},
        {"mesh", {"type", "name", "material", "position", "rotation_deg", "scale", "positions", "normals", "uvs", "indices"}},
        {"gltf", {"type", "name", "path", "position", "rotation_deg", "scale", "import_lights", "import_camera"}}};
    const auto fields = kFields.find(type);
    if (fields == kFields.end()) return r.fail(p + ".type", "must be sphere, plane, box, mesh or gltf");
    if (!r.object(j, p, fields->second)) return;
    const Mat4 transform = read_transform(r, j, p);
    if (type == "gltf") {
      import_gltf_object(r, j, p, transform, s, options);
      continue;
    }
    const int material = read_material_ref(r, j, p, s, names);
    read_shape(r, j, p, type, s, triangles, options);
    if (triangles > options.limits.max_triangles)
      return r.fail("objects", fmt::format("more than {} triangles", options.limits.max_triangles));
    if (r.failed()) return;
    s.instances.push_back({static_cast<int>(s.meshes.size() - 1), material, transform});
  }
}

// "environment": {"file": ..., "scale": ..., "rotation_deg": ...} or {"sky": {...}, ...}.
SkyParams read_sky(Reader& r, const json& j, const std::string& p) {
  SkyParams sky;
  if (!r.object(j, p, {"sun_elevation_deg", "sun_azimuth_deg", "turbidity", "ground_albedo", "sun"})) return sky;
  sky.sun_elevation_deg = r.number(j, p, "sun_elevation_deg", sky.sun_elevation_deg, 0, 90);
  sky.sun_azimuth_deg = r.number(j, p, "sun_azimuth_deg", sky.sun_azimuth_deg, -360, 360);
  sky.turbidity = r.number(j, p, "turbidity", sky.turbidity, 1.7, 10);
  sky.ground_albedo = r.number(j, p, "ground_albedo", sky.ground_albedo, 0, 1);
  sky.sun = r.boolean(j, p, "sun", sky.sun);
  return sky;
}

void read_environment(Reader& r, const json& j, Scene& s, const SceneLoadOptions& options) {
  const std::string p = "environment";
  if (!r.object(j, p, {"file", "sky", "scale", "rotation_deg"})) return;
  EnvironmentSpec e;
  if (j.contains("file") == j.contains("sky")) return r.fail(p, "give exactly one of file and sky");
  if (j.contains("sky")) {
    e.sky = read_sky(r, j["sky"], p + ".sky");
  } else {
    const std::string file = r.string(j, p, "file", "");
    if (r.failed()) return;
    if (file.empty()) return r.fail(p + ".file", "must not be empty");
    if (!options.allow_files) return r.fail(p + ".file", "file references are not allowed here");
    const std::filesystem::path path(file);
    e.file = path.is_absolute() ? path : options.base_dir / path;
    e.files = options.files;
  }
  e.scale = r.number(j, p, "scale", 1, 0, kBig);
  e.rotation_deg = r.number(j, p, "rotation_deg", 0, -3600, 3600);
  if (!r.failed() && s.ambient_nits) return r.fail("ambient_nits", "give either ambient_nits or environment, not both");
  s.environment = std::move(e);
}

// ---- Keyframes (docs/scene-format.md "Keyframes") -----------------------------------------------
constexpr std::size_t kMaxKeys = 100'000;

// A key list: [ {"t": ...}, ... ] (linear) or {"interpolation": "...", "keys": [...]} (plus
// `extra` keys of the wrapper, e.g. "light"). Null when absent or failed.
const json* read_key_list(Reader& r, const json& j, const std::string& p, Interpolation& interp,
                          std::vector<std::string_view> wrapper_keys = {}) {
  interp = Interpolation::linear;
  if (j.is_array() && wrapper_keys.empty()) {
    if (j.size() > kMaxKeys) return r.fail(p, fmt::format("{} keys exceed the limit of {}", j.size(), kMaxKeys)), nullptr;
    return &j;
  }
  wrapper_keys.insert(wrapper_keys.end(), {"interpolation", "keys"});
  if (!r.object(j, p, wrapper_keys)) return nullptr;
  const std::string name = r.string(j, p, "interpolation", "linear");
  if (name == "linear") interp = Interpolation::linear;
  else if (name == "step") interp = Interpolation::step;
  else if (name == "smooth") interp = Interpolation::smooth;
  else if (!r.failed()) return r.fail(p + ".interpolation", fmt::format("'{}' is not linear, step or smooth", name)), nullptr;
  const json* keys = r.array(j, p, "keys", kMaxKeys);
  if (!keys && !r.failed()) r.fail(p + ".keys", "missing");
  return keys;
}

// The keys' times: present, >= 0, strictly increasing.
std::vector<double> read_key_times(Reader& r, const json& keys, const std::string& p) {
  std::vector<double> times;
  if (keys.empty()) return r.fail(p, "has no keys"), times;
  for (std::size_t k = 0; k < keys.size() && !r.failed(); ++k) {
    const std::string kp = fmt::format("{}[{}]", p, k);
    if (!keys[k].is_object()) return r.fail(kp, "must be an object"), times;
    if (!keys[k].contains("t")) return r.fail(kp + ".t", "missing (the key's time in seconds)"), times;
    const double t = r.number(keys[k], kp, "t", 0, 0, kBig);
    if (!times.empty() && !(t > times.back()))
      r.fail(kp + ".t", fmt::format("{} s must be later than the key before ({} s)", t, times.back()));
    times.push_back(t);
  }
  return times;
}

// Appends one key of `components` values to a per-field track (built on its first key).
void add_key(std::optional<Track>& track, Interpolation interp, int components, double t, const double* v) {
  if (!track) {
    track.emplace();
    track->interpolation = interp;
    track->components = components;
  }
  track->times_s.push_back(t);
  track->values.insert(track->values.end(), v, v + components);
}
void add_vec3(std::optional<Track>& track, Interpolation interp, double t, std::optional<Vec3> v) {
  if (!v) return;
  const double c[3] = {v->x, v->y, v->z};
  add_key(track, interp, 3, t, c);
}
void add_scalar(std::optional<Track>& track, Interpolation interp, double t, std::optional<double> v) {
  if (v) add_key(track, interp, 1, t, &*v);
}

// A cut key holds, on every camera track with a key at the cut, the segment before it.
void hold_before(std::optional<Track>& track, double cut_s) {
  if (!track) return;
  const auto it = std::find(track->times_s.begin(), track->times_s.end(), cut_s);
  if (it != track->times_s.end() && it != track->times_s.begin())
    track->cut_keys.push_back(static_cast<std::size_t>(it - track->times_s.begin()));
}

void read_camera_keys(Reader& r, const json& j, SceneAnimation& a) {
  const std::string p = "keyframes.camera";
  Interpolation interp;
  const json* keys = read_key_list(r, j, p, interp);
  if (!keys) return;
  const std::vector<double> times = read_key_times(r, *keys, p);
  CameraAnimation c;
  for (std::size_t k = 0; k < times.size() && !r.failed(); ++k) {
    const json& key = (*keys)[k];
    const std::string kp = fmt::format("{}[{}]", p, k);
    if (!r.object(key, kp, {"t", "position", "target", "yaw_deg", "pitch_deg", "yfov_deg", "cut"})) return;
    add_vec3(c.position, interp, times[k], r.opt_vec3(key, kp, "position", -kBig, kBig));
    add_vec3(c.target, interp, times[k], r.opt_vec3(key, kp, "target", -kBig, kBig));
    add_scalar(c.yfov_deg, interp, times[k], r.opt_number(key, kp, "yfov_deg", 0.01, 179.9));
    const auto yaw = r.opt_number(key, kp, "yaw_deg", -3600, 3600), pitch = r.opt_number(key, kp, "pitch_deg", -89.9, 89.9);
    if (yaw.has_value() != pitch.has_value()) return r.fail(kp + (yaw ? ".pitch_deg" : ".yaw_deg"), "missing (yaw_deg and pitch_deg come together)");
    if (yaw) {
      const double yp[2] = {*yaw, *pitch};
      add_key(c.yaw_pitch_deg, interp, 2, times[k], yp);
    }
    if (r.boolean(key, kp, "cut", false)) c.cut_times_s.push_back(times[k]);
  }
  if (r.failed()) return;
  if (c.target && c.yaw_pitch_deg) return r.fail(p, "keys give both target and yaw_deg/pitch_deg: use one of them");
  for (double cut : c.cut_times_s)
    for (auto* t : {&c.position, &c.target, &c.yfov_deg, &c.yaw_pitch_deg}) hold_before(*t, cut);
  a.camera = std::move(c);
}

int find_light(Reader& r, const json& j, const std::string& p, const Scene& s) {
  const auto it = j.find("light");
  if (it == j.end()) return r.fail(p + ".light", "missing (a light's index or name)"), -1;
  if (it->is_number_integer() && it->get<std::int64_t>() >= 0) {
    const auto i = it->get<std::uint64_t>();
    if (i >= s.lights.size()) return r.fail(p + ".light", fmt::format("light {} does not exist ({} lights)", i, s.lights.size())), -1;
    return static_cast<int>(i);
  }
  if (!it->is_string()) return r.fail(p + ".light", "must be a light's index or name"), -1;
  int found = -1;
  for (std::size_t i = 0; i < s.lights.size(); ++i)
    if (s.lights[i].name == it->get<std::string>()) {
      if (found >= 0) return r.fail(p + ".light", fmt::format("'{}' names more than one light", it->get<std::string>())), -1;
      found = static_cast<int>(i);
    }
  if (found < 0) r.fail(p + ".light", fmt::format("no light is named '{}'", it->get<std::string>()));
  return found;
}

void read_light_keys(Reader& r, const json& j, const std::string& p, const Scene& s, SceneAnimation& a) {
  if (!j.is_object()) return r.fail(p, "must be an object with \"light\" and \"keys\"");
  Interpolation interp;
  const json* keys = read_key_list(r, j, p, interp, {"light"});
  const int index = find_light(r, j, p, s);
  if (!keys || r.failed()) return;
  const Light& light = s.lights[static_cast<std::size_t>(index)];
  const bool directional = light.type == LightType::directional;
  const char* amount = directional ? "illuminance_lux" : "intensity_cd";
  const std::vector<double> times = read_key_times(r, *keys, p + ".keys");
  LightAnimation la;
  la.light = index;
  for (std::size_t k = 0; k < times.size() && !r.failed(); ++k) {
    const json& key = (*keys)[k];
    const std::string kp = fmt::format("{}.keys[{}]", p, k);
    std::vector<std::string_view> allowed{"t", amount, "color"};
    if (!directional) allowed.push_back("position");
    if (!r.object(key, kp, allowed)) return;
    add_scalar(la.amount, interp, times[k], r.opt_number(key, kp, amount, 0, kBig));
    add_vec3(la.color, interp, times[k], r.opt_vec3(key, kp, "color", 0, kBig, true));
    add_vec3(la.position, interp, times[k], r.opt_vec3(key, kp, "position", -kBig, kBig));
  }
  a.lights.push_back(std::move(la));
}

void read_exposure_keys(Reader& r, const json& j, SceneAnimation& a) {
  const std::string p = "keyframes.exposure";
  Interpolation interp;
  const json* keys = read_key_list(r, j, p, interp);
  if (!keys) return;
  const std::vector<double> times = read_key_times(r, *keys, p);
  for (std::size_t k = 0; k < times.size() && !r.failed(); ++k) {
    const json& key = (*keys)[k];
    const std::string kp = fmt::format("{}[{}]", p, k);
    if (!r.object(key, kp, {"t", "ev100", "compensation_ev"})) return;
    add_scalar(a.exposure_ev100, interp, times[k], r.opt_number(key, kp, "ev100", -20, 30));
    add_scalar(a.exposure_compensation_ev, interp, times[k], r.opt_number(key, kp, "compensation_ev", -20, 20));
  }
}

void read_keyframes(Reader& r, const json& j, Scene& s) {
  const std::string p = "keyframes";
  if (!r.object(j, p, {"camera", "lights", "exposure"})) return;
  SceneAnimation a;
  if (j.contains("camera")) read_camera_keys(r, j["camera"], a);
  if (const json* lights = r.array(j, p, "lights", static_cast<std::size_t>(SceneLimits{}.max_lights) * 4))
    for (std::size_t i = 0; i < lights->size() && !r.failed(); ++i)
      read_light_keys(r, (*lights)[i], fmt::format("keyframes.lights[{}]", i), s, a);
  if (j.contains("exposure")) read_exposure_keys(r, j["exposure"], a);
  if (r.failed()) return;
  for (const std::optional<Track>* t : {&a.exposure_ev100, &a.exposure_compensation_ev})
    if (*t)
      if (auto v = validate_track(**t, p, "scene.json"); !v) return r.fail(p, v.error().message);
  if (!a.empty()) s.animation = std::make_shared<SceneAnimation>(std::move(a));
}

void read_scene(Reader& r, const json& doc, Scene& s, const SceneLoadOptions& options) {
  if (!r.object(doc, "", {"hdrd_scene", "name", "camera", "medium_ior", "ambient_nits", "background_nits",
                          "environment", "materials", "lights", "objects", "keyframes"}))
    return;
  if (!doc.contains("hdrd_scene")) return r.fail("hdrd_scene", fmt::format("missing (must be {})", kFormatVersion));
  if (r.number(doc, "", "hdrd_scene", 0, kFormatVersion, kFormatVersion) != kFormatVersion) return;
  s.name = r.string(doc, "", "name", "json");
  if (doc.contains("camera")) read_camera(r, doc["camera"], s);
  s.medium_ior = r.number(doc, "", "medium_ior", 1, 1, 3);
  s.ambient_nits = r.opt_vec3(doc, "", "ambient_nits", 0, kBig, true);
  s.background_nits = r.opt_vec3(doc, "", "background_nits", 0, kBig, true);
  if (doc.contains("environment")) read_environment(r, doc["environment"], s, options);

  std::map<std::string, int> names;
  if (const json* mats = r.array(doc, "", "materials", options.limits.max_materials))
    for (std::size_t i = 0; i < mats->size() && !r.failed(); ++i) {
      const std::string p = fmt::format("materials[{}]", i);
      Material m = read_material(r, (*mats)[i], p);
      if (!m.name.empty() && !names.emplace(m.name, static_cast<int>(i)).second)
        r.fail(p + ".name", fmt::format("'{}' is used twice", m.name));
      s.materials.push_back(std::move(m));
    }
  if (const json* lights = r.array(doc, "", "lights", static_cast<std::size_t>(options.limits.max_lights)))
    for (std::size_t i = 0; i < lights->size() && !r.failed(); ++i)
      s.lights.push_back(read_light(r, (*lights)[i], fmt::format("lights[{}]", i)));
  read_objects(r, doc, s, names, options);
  if (doc.contains("keyframes") && !r.failed()) read_keyframes(r, doc["keyframes"], s);
}

}  // namespace

Result<Scene> parse_scene_json(const nlohmann::json& doc, const SceneLoadOptions& options) {
  Reader r;
  Scene s;
  read_scene(r, doc, s, options);
  if (r.failed()) return r.error();
  if (auto v = validate(s, options.limits); !v) return v.error();
  return s;
}

Result<Scene> parse_scene_json_text(std::string_view text, const SceneLoadOptions& options) {
  // Bounded before anything is built (a deep text would crash whatever recurses on it
  // later), and a number beyond double's range is an error naming its field.
  auto doc = io::parse_json_bounded(text, io::JsonBounds{kMaxSceneJsonBytes, kMaxSceneJsonDepth, "scene", "scene.json_"});
  if (!doc) return doc.error();
  return parse_scene_json(*doc, options);
}

}  // namespace hdrd::shading

// Built-in scenes that exercise the shading theory (RTR4 ch. 9); see docs/rendering.md.
#include <cmath>
#include <functional>
#include <memory>

#include <fmt/format.h>

#include "shading/animation.hpp"
#include "shading/materials.hpp"
#include "shading/scene_loader.hpp"
#include "shading/shapes.hpp"

namespace hdrd::shading {
namespace {

class Builder {
 public:
  explicit Builder(std::string name) { s_.name = std::move(name); }
  int material(Material m) {
    s_.materials.push_back(std::move(m));
    return static_cast<int>(s_.materials.size() - 1);
  }
  int mesh(Mesh m) {
    s_.meshes.push_back(std::move(m));
    return static_cast<int>(s_.meshes.size() - 1);
  }
  void add(int mesh, int material, const Mat4& transform) { s_.instances.push_back({mesh, material, transform}); }
  void box(int material, Vec3 center, Vec3 size) {
    add(mesh(make_box(size)), material, translate(center));
  }
  Scene& scene() { return s_; }

 private:
  Scene s_;
};

Material plain(std::string name, Vec3 base, double roughness, double metallic = 0) {
  Material m;
  m.name = std::move(name);
  m.base_color = base;
  m.roughness = roughness;
  m.metallic = metallic;
  return m;
}

// A sphere's material from an F0 preset: metals take F0 as base colour (metalness
// workflow), dielectrics keep `dielectric_base` and take F0 as their dielectric F0.
Material from_preset(const F0Preset& p, double roughness, Vec3 dielectric_base) {
  Material m = plain(std::string(p.name), dielectric_base, roughness);
  if (p.kind == PresetKind::metal) {
    m.metallic = 1;
    m.base_color = p.f0_air;
    m.metal_n = preset_metal_n(p);
  } else {
    m.dielectric_f0 = p.f0_air.x;
  }
  return m;
}

Light sun(Vec3 travel, double lux, Vec3 color = {1, 1, 1}) {
  Light l;
  l.name = "sun";
  l.type = LightType::directional;
  l.direction = normalize(travel);
  l.illuminance_lux = lux;
  l.color = color;
  return l;
}

// The built-in sky (Preetham 1999) with its sun.
EnvironmentSpec sky(double elevation_deg, double azimuth_deg, double turbidity) {
  EnvironmentSpec e;
  e.sky = SkyParams{};
  e.sky->sun_elevation_deg = elevation_deg;
  e.sky->sun_azimuth_deg = azimuth_deg;
  e.sky->turbidity = turbidity;
  return e;
}

Light point(Vec3 position, double candela, double range_m = 0) {
  Light l;
  l.name = "lamp";
  l.type = LightType::point;
  l.position = position;
  l.intensity_cd = candela;
  l.range_m = range_m;
  return l;
}

// A row of spheres along x at height y, one per material, spaced 1 m.
void sphere_row(Builder& b, int sphere, const std::vector<Material>& mats, double y, double x0 = 0) {
  for (std::size_t i = 0; i < mats.size(); ++i)
    b.add(sphere, b.material(mats[i]), translate({x0 + double(i), y, 0}) * scale({0.4, 0.4, 0.4}));
}

std::vector<Material> roughness_sweep(const Material& base, int n) {
  std::vector<Material> out;
  for (int i = 0; i < n; ++i) {
    Material m = base;
    m.roughness = double(i) / (n - 1);
    m.name = fmt::format("{} r{:.2f}", base.name, m.roughness);
    out.push_back(m);
  }
  return out;
}

// Metals of table 9.2, dielectrics of table 9.1, roughness sweeps of gold and white plastic.
Scene material_grid() {
  Builder b("material-grid");
  const int sphere = b.mesh(make_sphere(1.0, 48, 24));
  std::vector<Material> metals, dielectrics;
  for (const F0Preset& p : f0_presets()) {
    if (p.kind == PresetKind::metal) metals.push_back(from_preset(p, 0.25, {0, 0, 0}));
    else dielectrics.push_back(from_preset(p, 0.25, {0.18, 0.18, 0.18}));
  }
  sphere_row(b, sphere, metals, 3.5);
  sphere_row(b, sphere, dielectrics, 2.5);
  sphere_row(b, sphere, roughness_sweep(from_preset(*find_f0_preset("gold"), 0, {}), 14), 1.5);
  sphere_row(b, sphere, roughness_sweep(plain("white plastic", {0.8, 0.8, 0.8}, 0), 14), 0.5);
  b.add(b.mesh(make_plane(30, 12)), b.material(plain("floor", {0.3, 0.3, 0.3}, 0.8)), translate({6.5, 0, 0}));
  b.add(b.mesh(make_plane(30, 8)), b.material(plain("backdrop", {0.3, 0.3, 0.3}, 0.8)),
        translate({6.5, 4, -1.5}) * rotate_xyz_deg({90, 0, 0}));
  Scene& s = b.scene();
  s.environment = sky(44, 146, 2.5);  // the sun behind the camera, over its right shoulder
  s.camera = Camera{{6.5, 2.2, 13.5}, {6.5, 2.0, 0}, {0, 1, 0}, 36 * kPi / 180};
  return s;
}

// Black dielectrics (only the Fresnel term shows) at grazing angles: a long floor and
// spheres under a uniform sky, with a low sun ahead of the camera.
Scene fresnel() {
  Builder b("fresnel");
  Material floor = plain("glass floor", {0, 0, 0}, 0.05);
  floor.dielectric_f0 = 0.04;
  b.add(b.mesh(make_plane(60, 60)), b.material(floor), translate({0, 0, -28}));
  const int sphere = b.mesh(make_sphere(1.0, 64, 32));
  int i = 0;
  for (const char* name : {"water", "plastic", "gems", "diamond"}) {
    Material m = from_preset(*find_f0_preset(name), 0.05, {0, 0, 0});
    b.add(sphere, b.material(m), translate({-3.0 + 2.0 * i++, 0.8, -4}) * scale({0.8, 0.8, 0.8}));
  }
  Scene& s = b.scene();
  Light l = sun({0, -0.08, 1}, 50000);  // 4.6 degrees above the horizon, shining toward the camera
  l.cast_shadows = false;
  s.lights.push_back(l);
  s.ambient_nits = Vec3{1000, 1000, 1000};
  s.camera = Camera{{0, 1.5, 2}, {0, 0.6, -20}, {0, 1, 0}, 50 * kPi / 180};
  return s;
}

// White furnace: uniform radiance from every direction. A white Lambertian (rho = 1,
// F0 = F90 = 0) must return exactly the environment; nothing may return more.
Scene furnace() {
  Builder b("furnace");
  const int sphere = b.mesh(make_sphere(1.0, 48, 24));
  Material lambert = plain("white lambert", {1, 1, 1}, 1);
  lambert.dielectric_f0 = 0;
  lambert.f90 = 0;
  std::vector<Material> row0(7, lambert);
  sphere_row(b, sphere, row0, 2, 0);
  sphere_row(b, sphere, roughness_sweep(plain("white metal", {1, 1, 1}, 0, 1), 7), 1, 0);
  Material black = plain("black dielectric", {0, 0, 0}, 0);
  sphere_row(b, sphere, roughness_sweep(black, 7), 0, 0);
  Scene& s = b.scene();
  s.ambient_nits = Vec3{1000, 1000, 1000};
  s.camera = Camera{{3, 1, 8}, {3, 1, 0}, {0, 1, 0}, 40 * kPi / 180};
  // A furnace is read against its light: the 1000 cd/m2 around it is diffuse white, a
  // camera at EV100 log2(1000 / 1.2) = 9.70 (1 / (1.2 * 2^EV100) = 1/1000). A metering
  // camera would map the uniform frame to mid grey and show the white spheres grey.
  auto exposure = std::make_shared<SceneAnimation>();
  Track ev;
  ev.times_s = {0};
  ev.values = {std::log2(1000 / 1.2)};
  exposure->exposure_ev100 = ev;
  s.animation = exposure;
  return s;
}

// A track of Vec3 keys.
Track vec3_track(Interpolation interp, std::initializer_list<std::pair<double, Vec3>> keys) {
  Track t;
  t.interpolation = interp;
  t.components = 3;
  for (const auto& [time_s, v] : keys) {
    t.times_s.push_back(time_s);
    t.values.insert(t.values.end(), {v.x, v.y, v.z});
  }
  return t;
}

// The hdr scene's motion (kHdrWalkOutSeconds): the camera walks from the dark interior
// (t = 0: the still scene's view) through the door out into the sunlit yard, so the
// frame's luminance rises by more than ten stops (exposure adaptation's test).
std::shared_ptr<const SceneAnimation> hdr_walk_out() {
  auto a = std::make_shared<SceneAnimation>();
  CameraAnimation c;
  c.position = vec3_track(Interpolation::smooth, {{0.0, {0.6, 1.6, 7.4}},
                                                  {2.0, {0.3, 1.55, 4.0}},
                                                  {4.0, {0.0, 1.5, 0.6}},
                                                  {kHdrWalkOutSeconds, {0.0, 1.6, -3.5}}});
  c.target = vec3_track(Interpolation::smooth, {{0.0, {-0.2, 1.1, -5}}, {kHdrWalkOutSeconds, {-0.2, 1.0, -12}}});
  a->camera = std::move(c);
  return a;
}

// Sun + sky + a shadowed interior: from inside a dim room through a door into a sunlit
// yard (> 16 stops between the dark interior and the sunlit ground, more to the sun's
// highlight on a chrome sphere).
Scene hdr() {
  Builder b("hdr");
  Material wall = plain("interior wall", {0.5, 0.5, 0.5}, 0.9);
  wall.ambient_visibility = 0.0002;  // baked sky visibility: the room sees the sky only through the door
  const int w = b.material(wall);
  b.box(w, {0, 1.5, 8.1}, {6.4, 3, 0.2});      // back wall (behind the camera)
  b.box(w, {-3.1, 1.5, 4}, {0.2, 3, 8.4});     // left
  b.box(w, {3.1, 1.5, 4}, {0.2, 3, 8.4});      // right
  b.box(w, {0, 3.1, 4}, {6.4, 0.2, 8.4});      // ceiling
  b.box(w, {-2.1, 1.5, -0.1}, {2.2, 3, 0.2});  // front wall, left of the door
  b.box(w, {2.1, 1.5, -0.1}, {2.2, 3, 0.2});   // right of the door
  b.box(w, {0, 2.6, -0.1}, {2.0, 0.8, 0.2});   // lintel
  Material inside_floor = plain("interior floor", {0.3, 0.3, 0.3}, 0.8);
  inside_floor.ambient_visibility = 0.0002;
  b.add(b.mesh(make_plane(6, 8)), b.material(inside_floor), translate({0, 0.001, 4}));
  Material cabinet = plain("dark cabinet", {0.03, 0.03, 0.03}, 0.9);
  cabinet.ambient_visibility = 0.0001;
  b.box(b.material(cabinet), {-2.2, 0.9, 5.5}, {1.2, 1.8, 0.8});
  b.add(b.mesh(make_plane(60, 60)), b.material(plain("yard", {0.25, 0.25, 0.25}, 0.9)), translate({0, 0, -30.2}));
  const int sphere = b.mesh(make_sphere(1.0, 64, 32));
  b.add(sphere, b.material(plain("chrome", {0.549, 0.556, 0.554}, 0.05, 1)), translate({-1.5, 1, -6}));
  b.add(sphere, b.material(plain("white ball", {0.8, 0.8, 0.8}, 0.5)), translate({2.0, 1, -9}));
  Scene& s = b.scene();
  s.environment = sky(50, 45, 2.5);                 // a clear midday sky, the sun ahead and to the right
  s.lights.push_back(point({0.5, 2.6, 5.5}, 1.0));  // a 1 cd night light
  s.camera = Camera{{0.6, 1.6, 7.4}, {-0.2, 1.1, -5}, {0, 1, 0}, 62 * kPi / 180};
  s.animation = hdr_walk_out();
  return s;
}

// Under water (n1 = 1.33): table 9.4's metals and dielectrics; the "F0 < 0.02" cut-off
// is off, so skin (F0 0.0007 in water) keeps its faint specular.
Scene underwater() {
  Builder b("underwater");
  const int sphere = b.mesh(make_sphere(1.0, 48, 24));
  std::vector<Material> mats;
  for (const char* name : {"iron", "gold", "silver", "skin", "k7-glass", "diamond"})
    mats.push_back(from_preset(*find_f0_preset(name), 0.2, {0.05, 0.05, 0.05}));
  sphere_row(b, sphere, mats, 1.0);
  b.add(b.mesh(make_plane(40, 40)), b.material(plain("sand", {0.45, 0.4, 0.3}, 0.9)), translate({2.5, 0, 0}));
  Scene& s = b.scene();
  s.medium_ior = kWaterIor;
  s.lights.push_back(sun({0.3, -1, -0.4}, 20000, {0.35, 0.75, 1.0}));
  s.ambient_nits = Vec3{60, 220, 320};
  s.camera = Camera{{2.5, 2.0, 6}, {2.5, 0.8, 0}, {0, 1, 0}, 45 * kPi / 180};
  return s;
}

struct Entry {
  const char* name;
  Scene (*make)();
};
constexpr Entry kScenes[] = {{"material-grid", material_grid}, {"fresnel", fresnel}, {"furnace", furnace},
                             {"hdr", hdr}, {"underwater", underwater}};

}  // namespace

std::string default_scene_name() { return "material-grid"; }

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> names;
  for (const Entry& e : kScenes) names.emplace_back(e.name);
  return names;
}

bool is_builtin_scene(std::string_view name) {
  for (const Entry& e : kScenes)
    if (name == e.name) return true;
  return false;
}

Result<Scene> make_builtin_scene(std::string_view name) {
  for (const Entry& e : kScenes)
    if (name == e.name) return e.make();
  return make_error("scene.unknown",
                    fmt::format("unknown built-in scene '{}' (have: {})", name, fmt::join(builtin_scene_names(), ", ")),
                    "scene");
}

}  // namespace hdrd::shading

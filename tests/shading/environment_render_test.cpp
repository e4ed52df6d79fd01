// Environment light rendered on llvmpipe, against references computed here: white
// furnaces (the exact answer is the environment), the mirror direction, Monte Carlo
// integrals of the same maps (irradiance; direct environment light through the CPU
// BRDF), the Preetham model's horizontal illuminance written from the paper, the sun's
// disc integrated over the screen, metering ratios, and the shadow map's fit.
#include <gtest/gtest.h>

#include <random>

#include "encode/io/io.hpp"
#include "shading/brdf.hpp"
#include "shading/materials.hpp"
#include "shading/shapes.hpp"
#include "shading/sky.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/shading/sky_reference.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

using testing::luma;
using testing::pixel_ray;

constexpr int kW = 96, kH = 96;

using RadianceFn = Vec3 (*)(Vec3);

// An equirectangular EXR of `radiance` (cd/m2 = value x white_luminance).
std::filesystem::path write_map(const hdrd::testing::TempDir& dir, const std::string& name, RadianceFn radiance,
                                int width = 256, std::optional<double> white_luminance = std::nullopt) {
  const int height = width / 2;
  Image img(width, height);
  const double wl = white_luminance.value_or(1.0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Vec3 c = radiance(equirect_direction((x + 0.5) / width, (y + 0.5) / height)) / wl;
      float* p = img.px(x, y);
      p[0] = float(c.x), p[1] = float(c.y), p[2] = float(c.z), p[3] = 1;
    }
  io::ExrWriteOptions o;
  o.half = false;
  o.white_luminance = white_luminance;
  const auto path = dir / name;
  EXPECT_TRUE(io::write_exr(path, img, o).ok());
  return path;
}

Vec3 uniform_1000(Vec3) { return {1000, 1000, 1000}; }
Vec3 gradient(Vec3 d) { return Vec3{1000, 900, 800} * (1.6 + 0.5 * d.x + 0.3 * d.y - 0.2 * d.z); }
Vec3 studio(Vec3 d) {  // a soft window up and to the right over a dim, slightly warm room
  const double window = std::exp(-6 * (1 - dot(d, normalize(Vec3{0.6, 0.7, 0.4}))));
  return Vec3{200, 180, 160} * (1 + 0.5 * d.y) + Vec3{6000, 6500, 7000} * window;
}

// Spheres of radius 1 at `centres`, one material each, seen by a camera at +z.
Scene spheres(const std::vector<Material>& materials, const std::vector<Vec3>& centres, Camera cam) {
  Scene s;
  s.meshes.push_back(make_sphere(1.0, 96, 48));
  for (std::size_t i = 0; i < materials.size(); ++i) {
    s.materials.push_back(materials[i]);
    s.instances.push_back({0, static_cast<int>(i), translate(centres[i])});
  }
  s.camera = cam;
  return s;
}

Material lambert_white() {
  Material m;
  m.base_color = {1, 1, 1};
  m.dielectric_f0 = 0;
  m.f90 = 0;
  return m;
}

Material white_metal(double roughness) {
  Material m;
  m.base_color = {1, 1, 1};
  m.metallic = 1;
  m.roughness = roughness;
  return m;
}

RenderSettings settings(bool compensate = true, int w = kW, int h = kH) {
  RenderSettings r;
  r.width = w;
  r.height = h;
  r.samples = 1;
  r.energy_compensation = compensate;
  return r;
}

EnvironmentSpec file_env(const std::filesystem::path& p, double rotation_deg = 0, double scale = 1) {
  EnvironmentSpec e;
  e.file = p;
  e.rotation_deg = rotation_deg;
  e.scale = scale;
  return e;
}

// The normal where the ray through pixel (x, y) meets the unit sphere at `centre`, for
// pixels whose ray also meets a sphere of `inside` radius (well within the tessellated
// silhouette); otherwise nothing.
std::optional<Vec3> sphere_normal(const Camera& cam, int w, int h, int x, int y, Vec3 centre, double inside = 0.97) {
  const Vec3 d = pixel_ray(cam, w, h, x, y), oc = cam.position - centre;
  const double b = dot(oc, d), c = dot(oc, oc);
  if (b * b - (c - inside * inside) <= 0) return std::nullopt;
  const Vec3 p = cam.position + d * (-b - std::sqrt(b * b - (c - 1)));
  return normalize(p - centre);
}

Camera front_camera(Vec3 target = {0, 0, 0}, double distance = 4.5, double fov_deg = 30) {
  return Camera{target + Vec3{0, 0, distance}, target, {0, 1, 0}, fov_deg * kPi / 180};
}

TEST(EnvironmentRender, WhiteLambertianInAUniformMapReturnsItsRadiance) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  Scene s = spheres({lambert_white()}, {{0, 0, 0}}, front_camera());
  s.environment = file_env(write_map(dir, "uniform.exr", uniform_1000, 64));
  auto r = renderer.render(s, settings());
  ASSERT_TRUE(r.ok()) << r.error().message;
  int hits = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const float* p = r->scene_nits.px(x, y);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(p[c], 1000.0, 10.0) << x << "," << y;  // sphere and background
      hits += sphere_normal(r->camera, kW, kH, x, y, {0, 0, 0}).has_value();
    }
  EXPECT_GT(hits, 1000);
  EXPECT_NEAR(r->dominant_illuminance_lux, kPi * 1000, 0.01 * kPi * 1000);
}

TEST(EnvironmentRender, MetalWithF0OneKeepsItsEnergyOnlyWithCompensation) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const std::vector<double> roughness = {0.0, 0.5, 1.0};
  const std::vector<Vec3> centres = {{-2.2, 0, 0}, {0, 0, 0}, {2.2, 0, 0}};
  Scene s = spheres({white_metal(0), white_metal(0.5), white_metal(1)}, centres, front_camera({0, 0, 0}, 9, 40));
  s.environment = file_env(write_map(dir, "uniform.exr", uniform_1000, 64));
  const int w = 192, h = 64;
  auto on = renderer.render(s, settings(true, w, h)), off = renderer.render(s, settings(false, w, h));
  ASSERT_TRUE(on.ok() && off.ok()) << (on.ok() ? off.error().message : on.error().message);
  for (std::size_t k = 0; k < centres.size(); ++k) {
    int hits = 0;
    double lowest_on = 1e30;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const auto n = sphere_normal(on->camera, w, h, x, y, centres[k]);
        if (!n) continue;
        const double nv = dot(*n, normalize(on->camera.position - (centres[k] + *n)));
        if (nv < 0.15) continue;  // the last rim pixels straddle the silhouette
        const double with = luma(on->scene_nits.px(x, y)), without = luma(off->scene_nits.px(x, y));
        lowest_on = std::min(lowest_on, with);
        EXPECT_LE(with, 1000 * 1.002);
        // Single scattering returns E_ss(n.v, roughness) of the light (RTR4 eq. 9.8),
        // integrated here on the CPU; at roughness 1 and normal view 1 - ln 2 = 0.307.
        const double ess = brdf::single_scatter_albedo(nv, roughness[k], 2048);
        EXPECT_NEAR(without, 1000 * ess, 1000 * 0.02) << "roughness " << roughness[k] << " n.v " << nv;
        ++hits;
      }
    EXPECT_GT(hits, 100);
    EXPECT_GE(lowest_on, 980) << "roughness " << roughness[k];
  }
}

TEST(EnvironmentRender, MirrorSphereReflectsTheMapInTheMirrorDirection) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const auto map_path = write_map(dir, "gradient.exr", gradient, 512);
  std::vector<std::string> w;
  auto map = load_environment_map(map_path, w);
  ASSERT_TRUE(map.ok());
  for (double rotation : {0.0, 90.0, -135.0}) {
    Scene s = spheres({white_metal(0)}, {{0, 0, 0}}, front_camera());
    s.environment = file_env(map_path, rotation);
    auto r = renderer.render(s, settings());
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Mat4 to_env = environment_rotation(rotation);
    int hits = 0;
    double worst = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const Vec3 d = pixel_ray(r->camera, kW, kH, x, y);
        const auto n = sphere_normal(r->camera, kW, kH, x, y, {0, 0, 0});
        if (!sphere_normal(r->camera, kW, kH, x, y, {0, 0, 0}, 1.05)) {
          // The background is the map itself, through the same rotation.
          const Vec3 want = map->sample(to_env.transform_dir(d));
          EXPECT_NEAR(luma(r->scene_nits.px(x, y)), luminance(want), 0.01 * luminance(want));
          continue;
        }
        if (!n) continue;
        if (dot(*n, -d) < 0.2) continue;
        const Vec3 refl = d - *n * (2 * dot(d, *n));  // RTR4 eq. 9.15
        const Vec3 want = map->sample(to_env.transform_dir(refl));
        const float* p = r->scene_nits.px(x, y);
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(p[c] - want[c]) / want[c]);
        ++hits;
      }
    EXPECT_GT(hits, 1000);
    EXPECT_LT(worst, 0.02) << "rotation " << rotation;
  }
}

// Monte Carlo irradiance with stratified (jittered) cosine-distributed directions,
// strata^2 samples: E = pi * mean(L). Stratifying keeps the noise near 0.1 %.
Vec3 monte_carlo_irradiance(const EnvironmentMap& m, Vec3 n, int strata, std::mt19937& rng) {
  std::uniform_real_distribution<double> u01(0, 1);
  const Vec3 t = normalize(cross(std::abs(n.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}, n)), b = cross(n, t);
  Vec3 sum{0, 0, 0};
  for (int i = 0; i < strata; ++i)
    for (int j = 0; j < strata; ++j) {
      const double r = std::sqrt((i + u01(rng)) / strata), phi = 2 * kPi * (j + u01(rng)) / strata;
      sum = sum + m.sample(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1 - r * r)));
    }
  return sum * (kPi / (strata * strata));
}

TEST(EnvironmentRender, DiffuseIrradianceMatchesMonteCarloWithin1Percent) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const auto map_path = write_map(dir, "studio.exr", studio, 512);
  std::vector<std::string> w;
  auto map = load_environment_map(map_path, w);
  ASSERT_TRUE(map.ok());
  Scene s = spheres({lambert_white()}, {{0, 0, 0}}, front_camera());
  s.environment = file_env(map_path, 30);
  auto r = renderer.render(s, settings());
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Mat4 to_env = environment_rotation(30);
  std::mt19937 rng(5);
  int checked = 0;
  for (int y = 8; y < kH; y += 9)
    for (int x = 8; x < kW; x += 9) {
      const auto n = sphere_normal(r->camera, kW, kH, x, y, {0, 0, 0}, 0.9);
      if (!n) continue;
      // A white Lambertian returns E / pi.
      const Vec3 want = monte_carlo_irradiance(*map, to_env.transform_dir(*n), 200, rng) / kPi;
      const float* p = r->scene_nits.px(x, y);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], want[c], 0.01 * want[c]) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, 30);
}

// Direct environment light by Monte Carlo on the CPU, L = integral f(l, v) L_env(l) (n.l)
// dl with f the CPU BRDF (single scattering), one estimator per lobe, stratified: the
// specular lobe by GGX importance sampling (pdf D (n.h) / (4 v.h), Walter et al. 2007),
// the diffuse lobe by cosine sampling (pdf n.l / pi).
Vec3 monte_carlo_shade(const EnvironmentMap& m, const brdf::Lobes& lobes, Vec3 n, Vec3 v, int strata, std::mt19937& rng) {
  std::uniform_real_distribution<double> u01(0, 1);
  const Vec3 t = normalize(cross(std::abs(n.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}, n)), b = cross(n, t);
  brdf::Lobes specular = lobes;
  specular.diffuse_rho = {0, 0, 0};
  const double a2 = lobes.alpha * lobes.alpha;
  Vec3 sum{0, 0, 0};
  for (int i = 0; i < strata; ++i)
    for (int j = 0; j < strata; ++j) {
      const double u1 = (i + u01(rng)) / strata, u2 = (j + u01(rng)) / strata;
      const double r = std::sqrt(u1), phi = 2 * kPi * u2;
      const Vec3 ld = t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1 - u1));
      sum = sum + (brdf::evaluate(lobes, n, ld, v) - brdf::evaluate(specular, n, ld, v)) * m.sample(ld) * kPi;
      const double cos_h = std::sqrt((1 - u1) / (1 + (a2 - 1) * u1)), sin_h = std::sqrt(std::max(0.0, 1 - cos_h * cos_h));
      const Vec3 h = t * (sin_h * std::cos(phi)) + b * (sin_h * std::sin(phi)) + n * cos_h;
      const Vec3 ls = h * (2 * dot(v, h)) - v;
      const double nl = dot(n, ls), vh = dot(v, h);
      if (nl <= 0 || vh <= 0) continue;
      const double pdf = brdf::ggx_d(cos_h, lobes.alpha) * cos_h / (4 * vh);
      sum = sum + brdf::evaluate(specular, n, ls, v) * m.sample(ls) * (nl / pdf);
    }
  return sum / double(strata * strata);
}

TEST(EnvironmentRender, GpuMatchesCpuMonteCarloOfDirectEnvironmentLight) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const auto map_path = write_map(dir, "studio.exr", studio, 512);
  std::vector<std::string> w;
  auto map = load_environment_map(map_path, w);
  ASSERT_TRUE(map.ok());
  Material gold;
  gold.name = "gold r0.5";
  gold.base_color = find_f0_preset("gold")->f0_air;
  gold.metallic = 1;
  gold.roughness = 0.5;
  Material paint;
  paint.name = "red paint r0.35";
  paint.base_color = {0.6, 0.2, 0.1};
  paint.roughness = 0.35;
  // Stated tolerances (docs/rendering.md): the split sum against the exact integral on a
  // map with a 30:1 window, measured on llvmpipe: gold 5.7 % mean / 12.2 % worst, the
  // dielectric 0.7 % / 3.2 %.
  struct Case {
    Material m;
    double mean, worst;
  };
  for (const auto& [m, mean_tol, worst_tol] : {Case{gold, 0.07, 0.15}, Case{paint, 0.015, 0.05}}) {
    Scene s = spheres({m}, {{0, 0, 0}}, front_camera());
    s.environment = file_env(map_path);
    auto r = renderer.render(s, settings(false));
    ASSERT_TRUE(r.ok()) << r.error().message;
    brdf::Surface surf;
    surf.base_color = m.base_color;
    surf.metallic = m.metallic;
    surf.roughness = m.roughness;
    const brdf::Lobes lobes = brdf::resolve(surf);
    std::mt19937 rng(3);
    double sum_err = 0, worst = 0;
    int checked = 0;
    for (int y = 6; y < kH; y += 12)
      for (int x = 6; x < kW; x += 12) {
        const auto n = sphere_normal(r->camera, kW, kH, x, y, {0, 0, 0}, 0.9);
        if (!n) continue;
        const Vec3 v = -pixel_ray(r->camera, kW, kH, x, y);
        if (dot(*n, v) < 0.3) continue;
        const Vec3 want = monte_carlo_shade(*map, lobes, *n, v, 128, rng);
        const double e = std::abs(luma(r->scene_nits.px(x, y)) - luminance(want)) / luminance(want);
        if (std::getenv("HDRD_DEBUG_SPLIT_SUM"))
          std::printf("%s n.v %.2f gpu %.1f mc %.1f (%+.1f %%)\n", m.name.c_str(), dot(*n, v), luma(r->scene_nits.px(x, y)),
                      luminance(want), 100 * (luma(r->scene_nits.px(x, y)) / luminance(want) - 1));
        sum_err += e;
        worst = std::max(worst, e);
        ++checked;
      }
    ASSERT_GT(checked, 15);
    EXPECT_LT(sum_err / checked, mean_tol) << m.name << " mean relative error";
    EXPECT_LT(worst, worst_tol) << m.name << " worst relative error";
    std::printf("[ split-sum ] %s: mean %.2f %%, worst %.2f %% over %d pixels\n", m.name.c_str(), 100 * sum_err / checked,
                100 * worst, checked);
  }
}

TEST(EnvironmentRender, SkyHorizontalIlluminanceMatchesThePreethamModel) {
  HDRD_REQUIRE_RENDERER(renderer);
  for (const bool sun : {false, true}) {
    Scene s;
    s.meshes.push_back(make_plane(400, 400));
    s.materials.push_back(lambert_white());
    s.instances.push_back({0, 0, Mat4{}});
    s.camera = Camera{{0, 5, 1}, {0, 0, 0}, {0, 1, 0}, 20 * kPi / 180};
    EnvironmentSpec e;
    e.sky = SkyParams{};
    e.sky->sun_elevation_deg = 40;
    e.sky->turbidity = 3;
    e.sky->sun = sun;
    s.environment = e;
    auto r = renderer.render(s, settings(true, 32, 32));
    ASSERT_TRUE(r.ok()) << r.error().message;
    double want = testing::preetham_horizontal_lux(3, 40);
    if (sun) want += preetham_sun(*e.sky).illuminance_lux * std::sin(40 * kPi / 180);
    // A white Lambertian plane facing up: L = E_horizontal / pi.
    EXPECT_NEAR(kPi * luma(r->scene_nits.px(16, 16)), want, 0.02 * want) << (sun ? "sun and sky" : "sky");
  }
}

TEST(EnvironmentRender, SunDiscIntegratesToTheSunsIlluminance) {
  HDRD_REQUIRE_RENDERER(renderer);
  Scene s;
  s.meshes.push_back(make_plane(1, 1));
  s.materials.push_back(lambert_white());
  s.instances.push_back({0, 0, translate({0, -50, 0})});  // out of view
  EnvironmentSpec e;
  e.sky = SkyParams{};
  e.sky->sun_elevation_deg = 35;
  e.sky->sun_azimuth_deg = 70;
  s.environment = e;
  const Vec3 to_sun = direction_from_angles(70 * kPi / 180, 35 * kPi / 180);
  const int n = 128;
  s.camera = Camera{{0, 0, 0}, to_sun, {0, 1, 0}, 1.5 * kPi / 180};
  auto r = renderer.render(s, settings(true, n, n));
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Sun sun = preetham_sun(*e.sky);
  // Sum of (L - sky) over the pixels' solid angles; the sky is the median pixel.
  std::vector<double> l;
  for (int i = 0; i < n * n; ++i) l.push_back(luma(r->scene_nits.rgba.data() + i * 4));
  std::vector<double> sorted = l;
  std::nth_element(sorted.begin(), sorted.begin() + n * n / 2, sorted.end());
  const double sky = sorted[n * n / 2];
  double sum = 0, peak = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double t = std::tan(s.camera->yfov_rad / 2) * 2 / n;
      const Vec3 d = pixel_ray(r->camera, n, n, x, y);
      const double cos_axis = dot(d, to_sun);
      sum += (l[y * n + x] - sky) * t * t * cos_axis * cos_axis * cos_axis;  // pixel solid angle
      peak = std::max(peak, l[y * n + x]);
    }
  EXPECT_NEAR(sum, sun.illuminance_lux, 0.03 * sun.illuminance_lux);
  EXPECT_NEAR(peak, sun.disc_luminance_nits + sky, 0.01 * sun.disc_luminance_nits);
  EXPECT_GT(peak, 1e9);  // the physical sun, not a clamped one
}

// The CIE standard overcast sky (Moon & Spencer 1942): L(theta) = Lz (1 + 2 cos theta) / 3,
// horizontal illuminance 7 pi Lz / 9; a black ground.
Vec3 overcast(Vec3 d) { return d.y > 0 ? Vec3{3000, 3000, 3000} * ((1 + 2 * d.y) / 3) : Vec3{0, 0, 0}; }

TEST(EnvironmentRender, SunlitAndOvercastSkiesMeterInProportion) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const auto overcast_path = write_map(dir, "overcast.exr", overcast, 512, 100.0);  // whiteLuminance 100
  auto card = [&](const EnvironmentSpec& e) {
    Scene s;
    s.meshes.push_back(make_plane(400, 400));
    s.materials.push_back(lambert_white());
    s.instances.push_back({0, 0, Mat4{}});
    s.camera = Camera{{0, 5, 1}, {0, 0, 0}, {0, 1, 0}, 20 * kPi / 180};
    s.environment = e;
    return renderer.render(s, settings(true, 16, 16));
  };
  auto dull = card(file_env(overcast_path));
  ASSERT_TRUE(dull.ok()) << dull.error().message;
  const double overcast_lux = 7 * kPi * 3000 / 9;
  EXPECT_NEAR(dull->dominant_illuminance_lux, overcast_lux, 0.02 * overcast_lux);
  EXPECT_NEAR(kPi * luma(dull->scene_nits.px(8, 8)), overcast_lux, 0.02 * overcast_lux);
  // Light-based exposure (scale pi / E) shows the white card at 1.0 under either sky.
  EXPECT_NEAR(luma(dull->scene_nits.px(8, 8)) * kPi / dull->dominant_illuminance_lux, 1.0, 0.02);

  EnvironmentSpec sunny;
  sunny.sky = SkyParams{};
  sunny.sky->sun_elevation_deg = 90;  // the card faces the sun: metering sees sun + sky on it
  sunny.sky->turbidity = 2.5;
  auto bright = card(sunny);
  ASSERT_TRUE(bright.ok()) << bright.error().message;
  const double sunny_lux = preetham_sun(*sunny.sky).illuminance_lux + testing::preetham_horizontal_lux(2.5, 90);
  EXPECT_NEAR(bright->dominant_illuminance_lux, sunny_lux, 0.02 * sunny_lux);
  // Their ratio is the ratio of the light: about 15x here.
  EXPECT_NEAR(bright->dominant_illuminance_lux / dull->dominant_illuminance_lux, sunny_lux / overcast_lux,
              0.03 * sunny_lux / overcast_lux);
  EXPECT_NEAR(luma(bright->scene_nits.px(8, 8)) / luma(dull->scene_nits.px(8, 8)), sunny_lux / overcast_lux,
              0.03 * sunny_lux / overcast_lux);
}

TEST(EnvironmentRender, GltfWithAnEnvironmentGetsNoDefaultRig) {
  HDRD_REQUIRE_RENDERER(renderer);
  HDRD_REQUIRE_FIXTURE(glb, "fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb");
  hdrd::testing::TempDir dir;
  RenderRequest q;
  q.scene = glb.string();
  q.width = 64;
  q.height = 64;
  q.samples = 1;
  auto plain = renderer.render(q);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  const auto has_rig = [](const RenderResult& r) {
    for (const auto& w : r.warnings)
      if (w.find("default rig") != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has_rig(*plain));
  q.environment = file_env(write_map(dir, "uniform.exr", uniform_1000, 64));
  auto lit = renderer.render(q);
  ASSERT_TRUE(lit.ok()) << lit.error().message;
  EXPECT_FALSE(has_rig(*lit));
  EXPECT_EQ(lit->environment, "uniform.exr");
  // Only the environment lights it: nothing brighter than the 1000 cd/m2 furnace.
  double peak = 0;
  for (std::size_t i = 0; i < lit->scene_nits.pixel_count(); ++i) peak = std::max(peak, luma(lit->scene_nits.rgba.data() + i * 4));
  EXPECT_LE(peak, 1000 * 1.002);
  EXPECT_NEAR(lit->dominant_illuminance_lux, kPi * 1000, 0.01 * kPi * 1000);
}

TEST(EnvironmentRender, PrefilteredMapsAreKeptBetweenFrames) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  const auto a = write_map(dir, "a.exr", gradient, 128), b = write_map(dir, "b.exr", studio, 128);
  Scene s = spheres({white_metal(0.3)}, {{0, 0, 0}}, front_camera());
  s.environment = file_env(a);
  auto first = renderer.render(s, settings(true, 32, 32));
  ASSERT_TRUE(first.ok());
  s.environment = file_env(a, 45, 2);  // rotation and scale apply per frame
  auto second = renderer.render(s, settings(true, 32, 32));
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second->environment_ms, 0);
  s.environment = file_env(b);
  auto third = renderer.render(s, settings(true, 32, 32));
  ASSERT_TRUE(third.ok());
  EXPECT_GT(third->environment_ms, 0);
  EXPECT_EQ(third->environment, "b.exr");
}

TEST(EnvironmentRender, GlesAndDesktopGlAgreeUnderTheSky) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto gles = Renderer::create(ContextOptions{Backend::egl, GlFlavor::gles});
  auto desk = Renderer::create(ContextOptions{Backend::egl, GlFlavor::desktop});
  if (!gles || !desk) GTEST_SKIP() << "needs both GLES 3.2 and GL 4.5 core";
  RenderRequest q;
  q.scene = "material-grid";  // the sky, its sun and shadows, every material
  q.width = 96;
  q.height = 54;
  auto a = (*desk)->render(q);
  auto b = (*gles)->render(q);
  ASSERT_TRUE(a.ok() && b.ok()) << (a.ok() ? b.error().message : a.error().message);
  for (std::size_t i = 0; i < a->scene_nits.rgba.size(); ++i)
    ASSERT_NEAR(a->scene_nits.rgba[i], b->scene_nits.rgba[i], 2e-3 * std::abs(a->scene_nits.rgba[i]) + 1e-3) << i;
}

TEST(EnvironmentRender, BadEnvironmentsAreClearErrors) {
  HDRD_REQUIRE_RENDERER(renderer);
  Scene s = spheres({lambert_white()}, {{0, 0, 0}}, front_camera());
  s.environment = file_env("/nonexistent/sky.exr");
  auto r = renderer.render(s, settings());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "environment.file");
  s.environment->scale = -1;
  r = renderer.render(s, settings());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "environment.scale");
  s.environment = EnvironmentSpec{};
  s.environment->sky = SkyParams{};
  s.ambient_nits = Vec3{1, 1, 1};
  r = renderer.render(s, settings());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "ambient_nits");
  RenderRequest q;
  q.environment = EnvironmentSpec{};  // neither file nor sky
  r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "environment");
}

TEST(EnvironmentRender, Rgba16fKeepsTheSunWhereItFitsAndSaysWhereItClamps) {
  HDRD_REQUIRE_RENDERER(renderer);
  Scene s;
  s.meshes.push_back(make_plane(1, 1));
  s.materials.push_back(lambert_white());
  s.instances.push_back({0, 0, translate({0, -50, 0})});
  EnvironmentSpec e;
  e.sky = SkyParams{};
  e.sky->sun_elevation_deg = 35;
  s.environment = e;
  s.camera = Camera{{0, 0, 0}, direction_from_angles(0, 35 * kPi / 180), {0, 1, 0}, 1.5 * kPi / 180};
  RenderSettings half = settings(true, 64, 64);
  half.target = TargetFormat::rgba16f;
  auto r = renderer.render(s, half);
  ASSERT_TRUE(r.ok()) << r.error().message;
  double peak = 0;
  for (float v : r->scene_nits.rgba) {
    ASSERT_TRUE(std::isfinite(v));
    peak = std::max(peak, double(v));
  }
  // Pre-exposed by pi / E (E = sun + sky on a card facing the sun), the disc stays below 65504.
  EXPECT_GT(peak, 1e9);
  for (const auto& w : r->warnings) EXPECT_EQ(w.find("clamped"), std::string::npos) << w;
  // The sky's sun is also the metered light, so its disc always fits. A map whose brightest
  // texel is tiny (one texel at the pole) does not: clamped there, and a warning says so.
  hdrd::testing::TempDir dir;
  Image img(512, 256);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = 100;
  for (int c = 0; c < 3; ++c) img.px(256, 0)[c] = 1e9f;
  io::ExrWriteOptions o;
  o.half = false;
  o.white_luminance = 1.0;
  ASSERT_TRUE(io::write_exr(dir / "spot.exr", img, o).ok());
  s.environment = file_env(dir / "spot.exr");
  s.camera = Camera{{0, 0, 0}, {0, 1, 0}, {0, 0, -1}, 60 * kPi / 180};
  r = renderer.render(s, half);
  ASSERT_TRUE(r.ok()) << r.error().message;
  bool warned = false;
  for (const auto& w : r->warnings) warned |= w.find("clamped") != std::string::npos && w.find("RGBA16F") != std::string::npos;
  EXPECT_TRUE(warned);
  for (float v : r->scene_nits.rgba) ASSERT_TRUE(std::isfinite(v));
}

// Does the ray o + t d (t > 0) meet the unit box [-0.5, 0.5] x [0, 1] x [-0.5, 0.5]? (slabs)
bool hits_unit_box(Vec3 o, Vec3 d) {
  double t0 = 1e-9, t1 = 1e9;
  for (int a = 0; a < 3; ++a) {
    const double lo = a == 1 ? 0.0 : -0.5, hi = a == 1 ? 1.0 : 0.5;
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < lo || o[a] > hi) return false;
      continue;
    }
    double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

TEST(EnvironmentRender, SunShadowMapIsFittedToTheViewAndFreeOfAcne) {
  HDRD_REQUIRE_RENDERER(renderer);
  // A 200 m floor, a 1 m box, a low sun (15 degrees, where acne shows first). The camera
  // sees a few metres: the view-fitted map's texels are far smaller than a fit to the
  // whole floor (200 m / 2048 = 0.1 m) would give.
  Scene s;
  s.meshes.push_back(make_plane(200, 200));
  s.meshes.push_back(make_box({1, 1, 1}));
  s.materials.push_back(lambert_white());
  s.instances.push_back({0, 0, Mat4{}});
  s.instances.push_back({1, 0, translate({0, 0.5, 0})});
  EnvironmentSpec e;
  e.sky = SkyParams{};
  e.sky->sun_elevation_deg = 15;
  e.sky->sun_azimuth_deg = 90;  // from +x: the shadow falls toward -x
  s.environment = e;
  s.camera = Camera{{-1.5, 6, 3}, {-1.5, 0, 0}, {0, 1, 0}, 50 * kPi / 180};
  const int w = 128, h = 96;
  auto r = renderer.render(s, settings(true, w, h));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_GT(r->shadow_texel_m, 0);
  EXPECT_LT(r->shadow_texel_m, 0.1 / 5);
  const Vec3 to_sun = direction_from_angles(kPi / 2, 15 * kPi / 180);
  const Sun sun = preetham_sun(*e.sky);
  // The sun's share on the floor: E_sun sin(15 deg) / pi for a white Lambertian.
  const double sun_share = sun.illuminance_lux * std::sin(15 * kPi / 180) / kPi;
  // PCF blurs the outline over about two texels of the map, stretched by 1 / sin(15 deg)
  // along the light on the floor; points that close to it are left out.
  const double margin_z = 3 * r->shadow_texel_m + 0.01, margin_x = margin_z / std::sin(15 * kPi / 180);
  std::vector<double> lit, shadowed;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 d = pixel_ray(r->camera, w, h, x, y);
      if (d.y >= 0 || hits_unit_box(r->camera.position, d)) continue;  // floor pixels only
      const Vec3 p = r->camera.position + d * (-r->camera.position.y / d.y);
      const bool blocked = hits_unit_box(p, to_sun);
      bool edge = false;
      for (double dx : {-margin_x, margin_x})
        for (double dz : {-margin_z, margin_z}) edge |= hits_unit_box(p + Vec3{dx, 0, dz}, to_sun) != blocked;
      if (edge) continue;
      (blocked ? shadowed : lit).push_back(luma(r->scene_nits.px(x, y)));
    }
  ASSERT_GT(lit.size(), 500u);
  ASSERT_GT(shadowed.size(), 100u);
  const auto [lit_lo, lit_hi] = std::minmax_element(lit.begin(), lit.end());
  const auto [sh_lo, sh_hi] = std::minmax_element(shadowed.begin(), shadowed.end());
  // No acne: every lit pixel has the sun's full share over the shadowed ones; no leaks:
  // every shadowed pixel lacks it. (The sky part is the same everywhere: no occlusion.)
  EXPECT_NEAR(*lit_lo - *sh_hi, sun_share, 0.02 * sun_share) << "lit " << *lit_lo << ".." << *lit_hi << ", shadow "
                                                              << *sh_lo << ".." << *sh_hi;
  EXPECT_LT(*lit_hi - *lit_lo, 0.005 * *lit_hi);
  EXPECT_LT(*sh_hi - *sh_lo, 0.005 * *sh_hi);
}

}  // namespace
}  // namespace hdrd::shading

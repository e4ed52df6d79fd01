// Rendered pixels against the CPU reference (RTR4 eq. 9.14), absolute anchors
// (REFERENCE.md §1.1), the white furnace, dynamic range, backends and render targets.
#include <gtest/gtest.h>

#include <algorithm>
#include <thread>

#include "shading/brdf.hpp"
#include "shading/materials.hpp"
#include "shading/shapes.hpp"
#include "tests/shading/render_testing.hpp"

namespace hdrd::shading {
namespace {

using testing::luma;
using testing::pixel_ray;

constexpr int kW = 96, kH = 64;

// A large horizontal plane (normal +y) with one material and the given lights.
Scene plane_scene(const Material& m, std::vector<Light> lights, double medium_ior = 1.0) {
  Scene s;
  s.name = "plane";
  s.meshes.push_back(make_plane(200, 200));
  s.materials.push_back(m);
  s.instances.push_back({0, 0, Mat4{}});
  s.lights = std::move(lights);
  s.medium_ior = medium_ior;
  s.camera = Camera{{0.3, 3, 5}, {0, 0, 0}, {0, 1, 0}, 50 * kPi / 180};
  return s;
}

RenderSettings small(int samples = 1, bool energy_compensation = false) {
  RenderSettings r;
  r.width = kW;
  r.height = kH;
  r.samples = samples;
  r.energy_compensation = energy_compensation;
  return r;
}

Light directional(Vec3 travel, double lux, Vec3 color = {1, 1, 1}) {
  Light l;
  l.type = LightType::directional;
  l.direction = normalize(travel);
  l.illuminance_lux = lux;
  l.color = color;
  l.cast_shadows = false;
  return l;
}

// KHR_lights_punctual's recommended falloff, written from the extension's text.
double punctual_attenuation(const Light& l, Vec3 p) {
  const Vec3 d = l.position - p;
  const double d2 = dot(d, d), dist = std::sqrt(d2);
  double a = 1.0 / d2;
  if (l.range_m > 0) a *= std::pow(std::clamp(1 - std::pow(dist / l.range_m, 4), 0.0, 1.0), 2);
  if (l.type == LightType::spot) {
    const double cd = dot(normalize(l.direction), normalize(p - l.position));
    const double scale = 1 / std::max(1e-3, std::cos(l.inner_cone_rad) - std::cos(l.outer_cone_rad));
    const double t = std::clamp((cd - std::cos(l.outer_cone_rad)) * scale, 0.0, 1.0);
    a *= t * t;
  }
  return a;
}

// CPU eq. 9.14 for the plane's point seen through pixel (x, y); with `compensate` the
// specular lobe carries the multiple-scattering factor, its E_ss integrated here.
Vec3 cpu_pixel(const Scene& s, const RenderResult& r, int x, int y, bool compensate) {
  const Material& m = s.materials[0];
  const Vec3 dir = pixel_ray(r.camera, kW, kH, x, y);
  const Vec3 p = r.camera.position + dir * (-r.camera.position.y / dir.y);
  const Vec3 n{0, 1, 0}, v = normalize(r.camera.position - p);
  brdf::Surface surf;
  surf.base_color = m.base_color;
  surf.metallic = m.metallic;
  surf.roughness = m.roughness;
  surf.dielectric_f0 = dielectric_f0_in_medium(m.dielectric_f0, s.medium_ior);
  surf.metal_n = m.metal_n;
  surf.medium_ior = s.medium_ior;
  const brdf::Lobes lobes = brdf::resolve(surf);
  const Vec3 ms = compensate ? brdf::energy_compensation(lobes, dot(n, v), m.roughness, 2048) : Vec3{1, 1, 1};
  Vec3 sum{0, 0, 0};
  for (const Light& l : s.lights) {
    if (l.type == LightType::directional) {
      sum = sum + brdf::shade(lobes, n, -normalize(l.direction), v, l.color * l.illuminance_lux, ms);
    } else {
      const Vec3 e = l.color * (l.intensity_cd * punctual_attenuation(l, p));
      sum = sum + brdf::shade(lobes, n, normalize(l.position - p), v, e, ms);
    }
  }
  return sum;
}

void expect_matches_cpu(Renderer& renderer, const Scene& scene, double rel_tol, bool compensate = false) {
  auto r = renderer.render(scene, small(1, compensate));
  ASSERT_TRUE(r.ok()) << r.error().message;
  int compared = 0;
  double peak = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) peak = std::max(peak, luma(r->scene_nits.px(x, y)));
  for (int y = kH / 2 + 1; y < kH; y += 3)  // the lower half sees the plane
    for (int x = 1; x < kW; x += 5) {
      const Vec3 want = cpu_pixel(scene, *r, x, y, compensate);
      const float* got = r->scene_nits.px(x, y);
      if (luminance(want) < 1e-3 * peak) continue;  // only where the value carries information
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(got[c], want[c], rel_tol * std::max(want[c], 1e-6 * peak)) << "pixel " << x << "," << y << " channel " << c;
      ++compared;
    }
  EXPECT_GT(compared, 40);
}

TEST(Render, ReportsBackendAndRenderer) {
  HDRD_REQUIRE_RENDERER(renderer);
  EXPECT_FALSE(renderer.context().gl_renderer().empty());
  EXPECT_FALSE(renderer.context().gl_version().empty());
  const std::string b = renderer.backend_name();
  EXPECT_TRUE(b == "egl-device" || b == "egl-surfaceless" || b == "osmesa") << b;
}

TEST(Render, DirectionalLightPixelsMatchCpuEq914) {
  HDRD_REQUIRE_RENDERER(renderer);
  Material copper;
  copper.base_color = find_f0_preset("copper")->f0_air;
  copper.metallic = 1;
  copper.roughness = 0.45;
  expect_matches_cpu(renderer, plane_scene(copper, {directional({0.3, -1, 0.2}, 10000)}), 1e-3);
  Material paint;
  paint.base_color = {0.6, 0.3, 0.1};
  paint.roughness = 0.3;
  paint.dielectric_f0 = 0.05;
  expect_matches_cpu(renderer, plane_scene(paint, {directional({-0.2, -0.6, -0.9}, 50000, {1, 0.9, 0.8})}), 1e-3);
}

TEST(Render, EnergyCompensationOfPunctualLightsMatchesCpu) {
  // Kulla & Conty's factor 1 + F0 (1/E_ss - 1), E_ss from the shader's table against E_ss
  // integrated on the CPU: a rough metal gains what single scattering loses.
  HDRD_REQUIRE_RENDERER(renderer);
  Material rough_gold;
  rough_gold.base_color = find_f0_preset("gold")->f0_air;
  rough_gold.metallic = 1;
  rough_gold.roughness = 0.8;
  const Scene s = plane_scene(rough_gold, {directional({0.3, -1, 0.2}, 10000)});
  expect_matches_cpu(renderer, s, 5e-3, true);
  auto on = renderer.render(s, small(1, true)), off = renderer.render(s, small(1, false));
  ASSERT_TRUE(on.ok() && off.ok());
  EXPECT_GT(luma(on->scene_nits.px(kW / 2, kH - 4)), 1.05 * luma(off->scene_nits.px(kW / 2, kH - 4)));
}

TEST(Render, PointAndSpotLightPixelsMatchCpuEq914) {
  HDRD_REQUIRE_RENDERER(renderer);
  Material m;
  m.base_color = {0.5, 0.5, 0.5};
  m.roughness = 0.5;
  Light point;
  point.type = LightType::point;
  point.position = {0.5, 1.5, 0.5};
  point.intensity_cd = 800;
  point.range_m = 4;  // the smooth window ends inside the view
  Light spot;
  spot.type = LightType::spot;
  spot.position = {-0.5, 2, -1};
  spot.direction = normalize(Vec3{0.2, -1, 0.3});
  spot.intensity_cd = 2000;
  spot.inner_cone_rad = 15 * kPi / 180;
  spot.outer_cone_rad = 35 * kPi / 180;
  expect_matches_cpu(renderer, plane_scene(m, {point, spot}), 1e-3);
}

TEST(Render, UnderwaterSkinKeepsItsSpecular) {
  HDRD_REQUIRE_RENDERER(renderer);
  Material skin;
  skin.base_color = {0.0, 0.0, 0.0};  // specular only: F0 = 0.0007 in water (table 9.4)
  skin.roughness = 0.3;
  skin.dielectric_f0 = find_f0_preset("skin")->f0_air.x;
  const Scene s = plane_scene(skin, {directional({0, -1, -0.5}, 100000)}, kWaterIor);
  expect_matches_cpu(renderer, s, 1e-3);
  // The air cut-off would have removed it: the rendered plane is not black.
  auto r = renderer.render(s, small());
  ASSERT_TRUE(r.ok());
  EXPECT_GT(luma(r->scene_nits.px(kW / 2, kH - 4)), 0.1);
}

TEST(Render, WhiteLambertianUnder100000LuxIs31831Nits) {
  HDRD_REQUIRE_RENDERER(renderer);
  Material white;
  white.base_color = {1, 1, 1};
  white.dielectric_f0 = 0;
  white.f90 = 0;  // Lambert only
  for (int samples : {1, 4}) {
    auto r = renderer.render(plane_scene(white, {directional({0, -1, 0}, 100000)}), small(samples));
    ASSERT_TRUE(r.ok()) << r.error().message;
    for (int x : {10, kW / 2, kW - 10}) {
      const float* p = r->scene_nits.px(x, kH - 5);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 31831.0, 31831.0 * 0.005) << "samples " << samples;
    }
    EXPECT_NEAR(r->dominant_illuminance_lux, 100000, 1e-6);
  }
  // REFERENCE.md §1.1's second anchor: rho = 0.5 under 1000 lux is 159.2 cd/m2.
  white.base_color = {0.5, 0.5, 0.5};
  auto r = renderer.render(plane_scene(white, {directional({0, -1, 0}, 1000)}), small());
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->scene_nits.px(kW / 2, kH - 5)[1], 159.15, 0.8);
}

TEST(Render, WhiteFurnaceReturnsItsLightNeverMore) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene = "furnace";
  q.width = 160;
  q.height = 90;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const double environment = 1000.0;
  double lowest = 1e30;
  for (std::size_t i = 0; i < r->scene_nits.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) {
      const float v = r->scene_nits.rgba[i * 4 + c];
      ASSERT_LE(v, environment * (1 + 1e-3)) << "pixel " << i;
      lowest = std::min(lowest, double(v));
    }
  // The white Lambertian spheres (top row) vanish into the environment: find a row
  // through them by projecting the sphere centre (3, 2, 0) and check a band of pixels.
  const Camera& cam = r->camera;
  int hits = 0;
  for (int y = 0; y < 90; ++y)
    for (int x = 0; x < 160; ++x) {
      const Vec3 d = pixel_ray(cam, 160, 90, x, y);
      const Vec3 oc = cam.position - Vec3{3, 2, 0};
      const double b = dot(oc, d), disc = b * b - (dot(oc, oc) - 0.35 * 0.35);
      if (disc <= 0) continue;  // well inside the 0.4 m sphere's silhouette
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r->scene_nits.px(x, y)[c], environment, environment * 1e-3);
      ++hits;
    }
  EXPECT_GT(hits, 20);
  EXPECT_LT(lowest, 0.5 * environment);  // the rough metals and black dielectrics do lose energy
}

TEST(Render, HdrSceneSpansMoreThan16Stops) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene = "hdr";
  q.width = 160;
  q.height = 90;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const double stops = dynamic_range_stops(r->scene_nits, 0.001, 0.999);
  EXPECT_GT(stops, 16.0);
  // Metered on a card facing the sky's sun: the sun (about 95 klx at 50 degrees, turbidity
  // 2.5) plus the sky on that card.
  EXPECT_GT(r->dominant_illuminance_lux, 95000);
  EXPECT_LT(r->dominant_illuminance_lux, 130000);
  EXPECT_NE(r->environment.find("sky"), std::string::npos);
}

TEST(Render, FresnelFloorBrightensTowardGrazing) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene = "fresnel";
  q.width = 160;
  q.height = 90;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  // Column x = 10 sees only the black glass floor below the horizon: reflected sky grows
  // from F0 (near, looking down) toward 1 (far, grazing), as Schlick's F does.
  double previous = 0;
  int rows = 0;
  for (int y = 89; y > 50; y -= 4) {
    const double v = luma(r->scene_nits.px(10, y));
    EXPECT_GT(v, previous) << "row " << y;  // brighter further up the image
    previous = v;
    ++rows;
  }
  EXPECT_GT(rows, 5);
  EXPECT_LT(luma(r->scene_nits.px(10, 89)), 0.2 * 1000);  // near F0 * sky
}

TEST(Render, Rgba16fMatchesRgba32fWithPreExposure) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto scene = make_builtin_scene("underwater");
  ASSERT_TRUE(scene.ok());
  RenderSettings s = small(1);
  auto full = renderer.render(*scene, s);
  s.target = TargetFormat::rgba16f;
  auto half = renderer.render(*scene, s);
  ASSERT_TRUE(full.ok() && half.ok());
  for (std::size_t i = 0; i < full->scene_nits.rgba.size(); ++i) {
    const float a = full->scene_nits.rgba[i], b = half->scene_nits.rgba[i];
    ASSERT_TRUE(std::isfinite(b));
    EXPECT_NEAR(b, a, 2e-3 * std::abs(a) + 1e-3) << i;  // half: 11 bits, rounded toward zero on llvmpipe
  }
}

TEST(Render, Rgba16fClampsInsteadOfOverflowing) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto scene = make_builtin_scene("hdr");  // the sun's highlight on chrome is ~1e8 cd/m2
  ASSERT_TRUE(scene.ok());
  RenderSettings s = small(1);
  s.target = TargetFormat::rgba16f;
  auto r = renderer.render(*scene, s);
  ASSERT_TRUE(r.ok());
  for (float v : r->scene_nits.rgba) ASSERT_TRUE(std::isfinite(v));
}

TEST(Render, MsaaResolveIsToneMapAware) {
  HDRD_REQUIRE_RENDERER(renderer);
  // A 100 000 cd/m2 emissive ball on a 10 cd/m2 background: a box filter lets the few
  // bright samples of an edge pixel dominate; the 1/(1 + luma) weights (RTR4 §5.4.2)
  // keep the edge close to what tone mapping each sample would give.
  Scene s;
  s.meshes.push_back(make_sphere(1.0, 64, 32));
  Material glow;
  glow.base_color = {0, 0, 0};
  glow.emissive_nits = {100000, 100000, 100000};
  s.materials.push_back(glow);
  s.instances.push_back({0, 0, Mat4{}});
  s.background_nits = Vec3{10, 10, 10};
  s.camera = Camera{{0, 0, 4}, {0, 0, 0}, {0, 1, 0}, 45 * kPi / 180};
  RenderSettings box = small(4), weighted = small(4);
  box.resolve = MsaaResolve::box;
  auto a = renderer.render(s, box);
  auto b = renderer.render(s, weighted);
  auto one = renderer.render(s, small(1));
  ASSERT_TRUE(a.ok() && b.ok() && one.ok());
  EXPECT_EQ(b->samples, 4);
  int edges = 0;
  for (std::size_t i = 0; i < a->scene_nits.pixel_count(); ++i) {
    const double box_v = a->scene_nits.rgba[i * 4], tm_v = b->scene_nits.rgba[i * 4];
    const double flat = one->scene_nits.rgba[i * 4];
    if (box_v == 10.0f || box_v == 100000.0f) {  // fully covered: all resolves agree
      EXPECT_FLOAT_EQ(tm_v, box_v);
      continue;
    }
    ++edges;
    EXPECT_LT(tm_v, box_v);  // partial coverage: bright samples weigh less
    EXPECT_GT(tm_v, 10.0);
    // Tone-mapped (Reinhard at white = 100 cd/m2) the weighted edge equals the mean of
    // the tone-mapped samples; with 4 samples the coverage is k/4 for some k.
    const auto reinhard = [](double v) { return v / 100 / (1 + v / 100); };
    const double tm = reinhard(tm_v);
    double best = 1e9;
    for (int k = 1; k <= 3; ++k)
      best = std::min(best, std::abs(tm - (k * reinhard(100000) + (4 - k) * reinhard(10)) / 4));
    EXPECT_LT(best, 0.02) << "pixel " << i << " box " << box_v << " weighted " << tm_v << " 1-sample " << flat;
  }
  EXPECT_GT(edges, 20);
}

TEST(Render, EglAndOsmesaAgree) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto osmesa = Renderer::create(Backend::osmesa);
  auto egl = Renderer::create(Backend::egl);
  if (!osmesa || !egl) GTEST_SKIP() << "needs both EGL and OSMesa";
  EXPECT_EQ((*osmesa)->backend_name(), "osmesa");
  RenderRequest q;
  q.scene = "material-grid";
  q.width = kW;
  q.height = kH;
  auto a = (*egl)->render(q);
  auto b = (*osmesa)->render(q);
  ASSERT_TRUE(a.ok() && b.ok());
  double worst = 0;
  for (std::size_t i = 0; i < a->scene_nits.rgba.size(); ++i)
    worst = std::max(worst, std::abs(double(a->scene_nits.rgba[i]) - b->scene_nits.rgba[i]) /
                                std::max(1.0, double(std::abs(a->scene_nits.rgba[i]))));
  EXPECT_LE(worst, 1e-4);  // same llvmpipe underneath: expected bit-identical
}

TEST(Render, GlesAndDesktopGlAgree) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto gles = Renderer::create(ContextOptions{Backend::egl, GlFlavor::gles});
  auto desk = Renderer::create(ContextOptions{Backend::egl, GlFlavor::desktop});
  if (!gles || !desk) GTEST_SKIP() << "needs both GLES 3.2 and GL 4.5 core";
  EXPECT_NE((*gles)->context().gl_version().find("OpenGL ES"), std::string::npos);
  RenderRequest q;
  q.scene = "underwater";
  q.width = kW;
  q.height = kH;
  auto a = (*desk)->render(q);
  auto b = (*gles)->render(q);
  ASSERT_TRUE(a.ok() && b.ok()) << (a.ok() ? b.error().message : a.error().message);
  for (std::size_t i = 0; i < a->scene_nits.rgba.size(); ++i)
    ASSERT_NEAR(a->scene_nits.rgba[i], b->scene_nits.rgba[i], 1e-3 * std::abs(a->scene_nits.rgba[i]) + 1e-3) << i;
}

TEST(Render, SurfacelessPlatformWorksToo) {
  HDRD_REQUIRE_RENDERER(renderer);
  auto r = Renderer::create(Backend::egl_surfaceless);
  if (!r) GTEST_SKIP() << r.error().message;
  EXPECT_EQ((*r)->backend_name(), "egl-surfaceless");
  RenderRequest q;
  q.width = 32;
  q.height = 16;
  auto f = (*r)->render(q);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->scene_name, default_scene_name());
}

TEST(Render, ReducedReadbackIsTheBlockMeanOfTheFrame) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene = "hdr";
  q.width = 100;  // not a multiple of the block: edge blocks average fewer pixels
  q.height = 60;
  auto full = renderer.render(q);
  ASSERT_TRUE(full.ok());
  q.readback = Readback::reduced;
  auto reduced = renderer.render(q);
  ASSERT_TRUE(reduced.ok());
  EXPECT_EQ(reduced->scene_nits.pixel_count(), 0u);
  const Image& m = reduced->metering_nits;
  ASSERT_EQ(m.width, 13);
  ASSERT_EQ(m.height, 8);
  // Block means counted from the bottom-left corner (GL's origin), rows then flipped.
  for (int by = 0; by < m.height; ++by)
    for (int bx = 0; bx < m.width; ++bx) {
      double sum[3] = {0, 0, 0};
      int n = 0;
      for (int gy = by * kMeteringBlock; gy < std::min(q.height, (by + 1) * kMeteringBlock); ++gy)
        for (int x = bx * kMeteringBlock; x < std::min(q.width, (bx + 1) * kMeteringBlock); ++x, ++n)
          for (int c = 0; c < 3; ++c) sum[c] += full->scene_nits.px(x, q.height - 1 - gy)[c];
      const float* p = m.px(bx, m.height - 1 - by);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], sum[c] / n, 1e-5 * sum[c] / n + 1e-6) << bx << "," << by;
    }
  // The full frame is still there.
  auto again = renderer.read_frame();
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->rgba, full->scene_nits.rgba);
}

TEST(Render, RenderersOnSeveralThreadsAtOnce) {
  HDRD_REQUIRE_RENDERER(renderer);
  // The daemon keeps one renderer per worker thread: two contexts rendering at the same
  // time must give the frames one renderer gives alone.
  RenderRequest q;
  q.scene = "underwater";
  q.width = 64;
  q.height = 36;
  auto reference = renderer.render(q);
  ASSERT_TRUE(reference.ok());
  std::vector<std::unique_ptr<Renderer>> renderers;
  for (int i = 0; i < 2; ++i) {
    auto r = Renderer::create(Backend::automatic);
    ASSERT_TRUE(r.ok()) << r.error().message;
    renderers.push_back(std::move(*r));
  }
  std::vector<Result<RenderResult>> results(4, make_error("x", "not run"));
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t)
    threads.emplace_back([&, t] {
      for (int k = 0; k < 2; ++k) results[t * 2 + k] = renderers[t]->render(q);
    });
  for (auto& t : threads) t.join();
  for (const auto& r : results) {
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->scene_nits.rgba, reference->scene_nits.rgba);
  }
  // A renderer may also move between threads (one at a time).
  std::thread([&] { EXPECT_TRUE(renderer.render(q).ok()); }).join();
  EXPECT_TRUE(renderer.render(q).ok());
}

TEST(Render, RejectsBadRequestsWithClearErrors) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.width = 100000;
  q.height = 10;
  auto r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("exceeds the limit"), std::string::npos) << r.error().message;
  q.width = 0;
  EXPECT_FALSE(renderer.render(q).ok());
  q.width = 64;
  q.samples = 64;
  r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "samples");
  q.samples = 1;
  q.scene = "no-such-scene";
  r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("material-grid"), std::string::npos) << "lists the built-ins";
  q.scene = "/nonexistent/dir/x.glb";
  r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("does not exist"), std::string::npos);
  q.backend = renderer.backend_name() == "osmesa" ? Backend::egl : Backend::osmesa;
  q.scene.clear();
  r = renderer.render(q);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "backend");
}

TEST(Render, RejectsNanAndDegenerateScenes) {
  HDRD_REQUIRE_RENDERER(renderer);
  Material m;
  Scene s = plane_scene(m, {directional({0, -1, 0}, 1000)});
  s.lights[0].illuminance_lux = std::nan("");
  auto r = renderer.render(s, small());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "lights[0].illuminance_lux");
  s = plane_scene(m, {});
  s.materials[0].roughness = std::nan("");
  r = renderer.render(s, small());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "materials[0].roughness");
  s = plane_scene(m, {});
  for (auto& v : s.meshes[0].vertices) v.position = {1, 2, 3};  // every triangle has zero area
  r = renderer.render(s, small());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no non-degenerate triangle"), std::string::npos);
  s = plane_scene(m, {});
  s.camera->target = s.camera->position;
  EXPECT_FALSE(renderer.render(s, small()).ok());
  s = plane_scene(m, {});
  s.instances[0].transform = scale({0, 1, 1});
  EXPECT_FALSE(renderer.render(s, small()).ok());
}

TEST(Render, CameraOverrideParses) {
  auto c = parse_camera_override("0,1.5,6:0,0.5,0:40");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(*c->position, (Vec3{0, 1.5, 6}));
  EXPECT_EQ(*c->target, (Vec3{0, 0.5, 0}));
  EXPECT_EQ(*c->yfov_deg, 40);
  EXPECT_TRUE(parse_camera_override("1,2,3").ok());
  for (const char* bad : {"", "1,2", "1,2,3:4", "1,2,3:4,5,6:0", "1,2,3:4,5,6:200", "a,b,c", "1,2,3:4,5,6:40:1", "nan,1,2"})
    EXPECT_FALSE(parse_camera_override(bad).ok()) << bad;
}

}  // namespace
}  // namespace hdrd::shading

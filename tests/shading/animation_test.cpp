// Scene animation: keyframe sampling against values computed here from the formulas
// (lerp, Shoemake's slerp, glTF 2.0 Appendix C's Hermite basis), glTF animations written
// by the test, JSON keyframes, and frames rendered at different times (the moved object's
// light moves by the projected distance; the hdr scene's walk-out gains many stops;
// the same time gives the same frame; the second frame reuses the loaded scene).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

#include "shading/animation.hpp"
#include "shading/scene_loader.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

using nlohmann::json;

Track track(Interpolation interp, int components, std::vector<double> times, std::vector<double> values) {
  Track t;
  t.interpolation = interp;
  t.components = components;
  t.rotation = components == 4;
  t.times_s = std::move(times);
  t.values = std::move(values);
  return t;
}

// ---- Sampling --------------------------------------------------------------------------------
TEST(Animation, LinearTranslationIsTheLerpAndClampsOutsideTheKeys) {
  const Track t = track(Interpolation::linear, 3, {1.0, 3.0}, {-1, 0, 2, 3, 4, -2});
  ASSERT_TRUE(validate_track(t, "t").ok());
  const auto at = sample(t, 1.5);  // u = 0.25
  EXPECT_DOUBLE_EQ(at[0], -1 + 0.25 * 4);
  EXPECT_DOUBLE_EQ(at[1], 0 + 0.25 * 4);
  EXPECT_DOUBLE_EQ(at[2], 2 + 0.25 * -4);
  EXPECT_EQ(sample(t, 0.0)[0], -1);   // before the first key: the first value
  EXPECT_EQ(sample(t, -5.0)[2], 2);
  EXPECT_EQ(sample(t, 3.0)[0], 3);    // at and after the last: the last value
  EXPECT_EQ(sample(t, 100.0)[1], 4);
}

TEST(Animation, LinearRotationIsTheShortestPathSlerp) {
  // q0: 30 degrees about Z; q1: 130 degrees about an oblique axis, stored negated
  // (the same rotation): slerp must take the short arc to -q1.
  const double a0 = 30 * kPi / 180, a1 = 130 * kPi / 180;
  const double ax[3] = {1 / std::sqrt(3.0), 1 / std::sqrt(3.0), 1 / std::sqrt(3.0)};
  const std::array<double, 4> q0{0, 0, std::sin(a0 / 2), std::cos(a0 / 2)};
  const std::array<double, 4> q1{ax[0] * std::sin(a1 / 2), ax[1] * std::sin(a1 / 2), ax[2] * std::sin(a1 / 2),
                                 std::cos(a1 / 2)};
  const std::array<double, 4> stored{-q1[0], -q1[1], -q1[2], -q1[3]};
  const Track t = track(Interpolation::linear, 4, {0, 2}, {q0[0], q0[1], q0[2], q0[3], stored[0], stored[1], stored[2], stored[3]});
  ASSERT_TRUE(validate_track(t, "t").ok());
  // Shoemake: cos theta = |q0 . q1|, q(u) = (sin((1-u) theta) q0 + sin(u theta) q1') / sin theta.
  const double d = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3];
  const std::array<double, 4> q1s = d < 0 ? stored : q1;
  const double theta = std::acos(std::abs(d)), u = 0.5;
  const auto got = sample(t, 1.0);
  for (int c = 0; c < 4; ++c) {
    const double want = (std::sin((1 - u) * theta) * q0[c] + std::sin(u * theta) * q1s[c]) / std::sin(theta);
    EXPECT_NEAR(got[c], want, 1e-12) << "component " << c;
  }
  EXPECT_NEAR(got[0] * got[0] + got[1] * got[1] + got[2] * got[2] + got[3] * got[3], 1.0, 1e-12);
  EXPECT_GT(got[3] * q0[3] + got[2] * q0[2], 0.0);  // stayed on q0's side: the short arc
}

TEST(Animation, StepHoldsThePreviousKey) {
  const Track t = track(Interpolation::step, 1, {0, 1, 2}, {5, 7, 11});
  EXPECT_EQ(sample(t, 0.0)[0], 5);
  EXPECT_EQ(sample(t, 0.999)[0], 5);
  EXPECT_EQ(sample(t, 1.0)[0], 7);
  EXPECT_EQ(sample(t, 1.5)[0], 7);
  EXPECT_EQ(sample(t, 2.5)[0], 11);
}

TEST(Animation, CubicSplineIsTheHermiteBasisWithTangentsScaledByTheInterval) {
  // Keys at 1 s and 3 s (td = 2); per key: in-tangent a, value v, out-tangent b.
  const double a0 = 9, v0 = 1, b0 = 2, a1 = -3, v1 = 4, b1 = 8;
  const Track t = track(Interpolation::cubic_spline, 1, {1, 3}, {a0, v0, b0, a1, v1, b1});
  ASSERT_TRUE(validate_track(t, "t").ok());
  for (double time : {1.25, 2.0, 2.9}) {
    const double td = 2, s = (time - 1) / td;
    const double want = (2 * s * s * s - 3 * s * s + 1) * v0 + (s * s * s - 2 * s * s + s) * td * b0 +
                        (-2 * s * s * s + 3 * s * s) * v1 + (s * s * s - s * s) * td * a1;
    EXPECT_NEAR(sample(t, time)[0], want, 1e-12) << time;
  }
  EXPECT_EQ(sample(t, 0.0)[0], v0);  // clamped to the values, never the tangents
  EXPECT_EQ(sample(t, 9.0)[0], v1);
}

TEST(Animation, CubicSplineRotationsAreNormalised) {
  const Track t = track(Interpolation::cubic_spline, 4, {0, 1},
                        {0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0});
  const auto q = sample(t, 0.5);
  EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
  // Hermite of (0,0,0,1) -> (0,1,0,0) with zero tangents at s = 0.5 is (0, .5, 0, .5): normalised.
  EXPECT_NEAR(q[1], std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(q[3], std::sqrt(0.5), 1e-12);
}

TEST(Animation, SmoothEasesInAndOutAndPassesThroughTheKeys) {
  const Track t = track(Interpolation::smooth, 1, {0, 1, 3}, {0, 1, 5});
  EXPECT_EQ(sample(t, 1.0)[0], 1);
  // Segment 0..1: m0 = 0 (an end), m1 = mean of slopes 1 and 2 = 1.5; Hermite at s = 0.5.
  const double s = 0.5, want = (-2 * s * s * s + 3 * s * s) * 1 + (s * s * s - s * s) * 1 * 1.5;
  EXPECT_NEAR(sample(t, 0.5)[0], want, 1e-12);
}

TEST(Animation, BadTracksAreErrorsNamingTheTrack) {
  const auto err = [](Track t) { return validate_track(t, "animations[2].samplers[1]").error().message; };
  EXPECT_NE(err(track(Interpolation::linear, 1, {0, 1, 1}, {0, 0, 0})).find("strictly increasing"), std::string::npos);
  EXPECT_NE(err(track(Interpolation::linear, 1, {0, 1}, {0})).find("2 keys"), std::string::npos);
  EXPECT_NE(err(track(Interpolation::cubic_spline, 1, {0, 1}, {0, 0})).find("in-tangent"), std::string::npos);
  EXPECT_NE(err(track(Interpolation::linear, 1, {0, NAN}, {0, 0})).find("animations[2].samplers[1]"), std::string::npos);
  EXPECT_NE(err(track(Interpolation::linear, 1, {0, 1}, {0, INFINITY})).find("not finite"), std::string::npos);
  EXPECT_NE(err(track(Interpolation::linear, 1, {}, {})).find("no keyframes"), std::string::npos);
}

// ---- glTF animations, written by the test -----------------------------------------------------
// A glTF 2.0 file with one emissive quad (0.5 m square in XY) on node 0, and animation
// samplers added by the test; written as .gltf + .bin.
struct GltfWriter {
  std::vector<std::uint8_t> bin;
  json doc;
  GltfWriter() {
    doc = {{"asset", {{"version", "2.0"}}},
           {"scene", 0},
           {"scenes", {{{"nodes", {0}}}}},
           {"nodes", {{{"mesh", 0}, {"name", "quad"}}}},
           {"materials", {{{"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 0, 1}}, {"metallicFactor", 0}}},
                           {"emissiveFactor", {1, 1, 1}},
                           {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 1000}}}}}}}},
           {"extensionsUsed", {"KHR_materials_emissive_strength"}},
           {"bufferViews", json::array()},
           {"accessors", json::array()},
           {"animations", json::array()}};
    const int pos = floats({-0.25f, -0.25f, 0, 0.25f, -0.25f, 0, 0.25f, 0.25f, 0, -0.25f, 0.25f, 0}, "VEC3");
    const std::uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    const int ind = raw(idx, sizeof idx, 5123, 6, "SCALAR");
    const json prim = {{"attributes", {{"POSITION", pos}}}, {"indices", ind}, {"material", 0}};
    doc["meshes"] = json::array({json{{"primitives", json::array({prim})}}});
    doc["accessors"][pos]["min"] = {-0.25, -0.25, 0};
    doc["accessors"][pos]["max"] = {0.25, 0.25, 0};
  }
  int raw(const void* data, std::size_t bytes, int component, std::size_t count, const char* type) {
    while (bin.size() % 4) bin.push_back(0);
    const std::size_t offset = bin.size();
    bin.insert(bin.end(), static_cast<const std::uint8_t*>(data), static_cast<const std::uint8_t*>(data) + bytes);
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}});
    doc["accessors"].push_back({{"bufferView", doc["bufferViews"].size() - 1}, {"componentType", component},
                                {"count", count}, {"type", type}});
    return static_cast<int>(doc["accessors"].size() - 1);
  }
  int floats(const std::vector<float>& v, const char* type) {
    const std::size_t n = std::string_view(type) == "SCALAR" ? 1 : std::string_view(type) == "VEC3" ? 3 : 4;
    return raw(v.data(), v.size() * 4, 5126, v.size() / n, type);
  }
  // One animation with one channel on `node`.
  void animate(int node, const char* path, const char* interp, const std::vector<float>& times,
               const std::vector<float>& values) {
    const int in = floats(times, "SCALAR");
    const int out = floats(values, std::string_view(path) == "rotation" ? "VEC4" : "VEC3");
    doc["accessors"][in]["min"] = {times.front()};
    doc["accessors"][in]["max"] = {times.back()};
    doc["animations"].push_back({{"name", std::string(path) + " " + interp},
                                 {"samplers", {{{"input", in}, {"output", out}, {"interpolation", interp}}}},
                                 {"channels", {{{"sampler", 0}, {"target", {{"node", node}, {"path", path}}}}}}});
  }
  std::filesystem::path write(const std::filesystem::path& dir, const std::string& name) {
    doc["buffers"] = {{{"byteLength", bin.size()}, {"uri", name + ".bin"}}};
    std::ofstream(dir / (name + ".bin"), std::ios::binary).write(reinterpret_cast<const char*>(bin.data()),
                                                                 static_cast<std::streamsize>(bin.size()));
    std::ofstream(dir / (name + ".gltf")) << doc.dump();
    return dir / (name + ".gltf");
  }
};

Vec3 instance_origin(const Scene& s, std::size_t i) { return s.instances.at(i).transform.transform_point({0, 0, 0}); }

TEST(GltfAnimation, TranslationRotationScaleChannelsPoseTheNodes) {
  hdrd::testing::TempDir dir;
  GltfWriter g;
  // Node 1, the quad's parent's child: quad under a parent that the test animates too.
  g.doc["nodes"] = {{{"children", {1}}, {"name", "parent"}}, {{"mesh", 0}, {"name", "quad"}}};
  g.animate(0, "translation", "LINEAR", {0, 2}, {-1, 0, 0, 1, 0, 0});
  const float h = float(std::sqrt(0.5));
  g.animate(1, "rotation", "LINEAR", {0, 1}, {0, 0, 0, 1, 0, h, 0, h});  // 0 -> 90 degrees about Y
  g.animate(1, "scale", "STEP", {0, 1}, {1, 1, 1, 2, 2, 2});
  auto scene = load_gltf_file(g.write(dir.path(), "trs"));
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_TRUE(scene->animation);
  EXPECT_DOUBLE_EQ(scene->animation->duration_s(), 2.0);
  auto f = animate(*scene, *scene->animation, 0.5);
  ASSERT_TRUE(f.ok()) << f.error().message;
  // Parent at x = -1 + 0.5 * (2 / 2) = -0.5; the child turned 45 degrees about Y, scale 1.
  const Mat4& m = scene->instances[0].transform;
  EXPECT_NEAR(m.transform_point({0, 0, 0}).x, -0.5, 1e-9);
  const Vec3 x_axis = m.transform_dir({1, 0, 0});
  EXPECT_NEAR(x_axis.x, std::cos(kPi / 4), 1e-7);
  EXPECT_NEAR(x_axis.z, -std::sin(kPi / 4), 1e-7);  // +X turns toward -Z under +Y rotation
  EXPECT_NEAR(length(x_axis), 1.0, 1e-7);
  ASSERT_TRUE(animate(*scene, *scene->animation, 1.5).ok());
  EXPECT_NEAR(instance_origin(*scene, 0).x, 0.5, 1e-9);
  EXPECT_NEAR(length(scene->instances[0].transform.transform_dir({1, 0, 0})), 2.0, 1e-6);  // STEP: scale 2 from t = 1
  ASSERT_TRUE(animate(*scene, *scene->animation, 7.0).ok());  // after the end: the last keys
  EXPECT_NEAR(instance_origin(*scene, 0).x, 1.0, 1e-9);
}

TEST(GltfAnimation, CubicSplineTranslationFollowsAppendixC) {
  hdrd::testing::TempDir dir;
  GltfWriter g;
  // Per key: in-tangent, value, out-tangent (VEC3 each); keys at 0 and 2 s.
  g.animate(0, "translation", "CUBICSPLINE", {0, 2}, {0, 0, 0, 0, 0, 0, 3, 0, 0, -1, 0, 0, 2, 0, 0, 0, 0, 0});
  auto scene = load_gltf_file(g.write(dir.path(), "cubic"));
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_TRUE(animate(*scene, *scene->animation, 0.5).ok());
  const double s = 0.25, td = 2;
  const double want = (s * s * s - 2 * s * s + s) * td * 3 + (-2 * s * s * s + 3 * s * s) * 2 + (s * s * s - s * s) * td * -1;
  EXPECT_NEAR(instance_origin(*scene, 0).x, want, 1e-6);
}

TEST(GltfAnimation, AnimatedCameraNodeMovesTheCamera) {
  hdrd::testing::TempDir dir;
  GltfWriter g;
  g.doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 0, 5}}});
  g.doc["scenes"][0]["nodes"].push_back(1);
  g.doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.7}, {"znear", 0.1}}}}};
  g.animate(1, "translation", "LINEAR", {0, 1}, {0, 0, 5, 2, 0, 5});
  auto scene = load_gltf_file(g.write(dir.path(), "camera"));
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_TRUE(animate(*scene, *scene->animation, 0.25).ok());
  EXPECT_NEAR(scene->camera->position.x, 0.5, 1e-9);
  EXPECT_NEAR(scene->camera->target.x, 0.5, 1e-9);
  EXPECT_NEAR(scene->camera->target.z, 4.0, 1e-9);
}

TEST(GltfAnimation, MalformedAnimationsAreClearErrors) {
  struct Case {
    std::string name, want;
    std::function<void(GltfWriter&)> edit;
  };
  const std::vector<Case> cases = {
      {"times not increasing", "strictly increasing", [](GltfWriter& g) { g.animate(0, "translation", "LINEAR", {0, 1, 1}, std::vector<float>(9, 0)); }},
      {"count mismatch", "output elements for 2 key times", [](GltfWriter& g) { g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(9, 0)); }},
      {"cubic without tangents", "in-tangent, value, out-tangent", [](GltfWriter& g) { g.animate(0, "translation", "CUBICSPLINE", {0, 1}, std::vector<float>(6, 0)); }},
      {"bad interpolation", "is not LINEAR, STEP or CUBICSPLINE", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["animations"][0]["samplers"][0]["interpolation"] = "BEZIER";
       }},
      {"missing node", "target node 7 does not exist", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["animations"][0]["channels"][0]["target"]["node"] = 7;
       }},
      {"missing sampler", "sampler 3 does not exist", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["animations"][0]["channels"][0]["sampler"] = 3;
       }},
      {"rotation as VEC3", "rotation needs 4", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["animations"][0]["channels"][0]["target"]["path"] = "rotation";
       }},
      {"integer times", "SCALAR float", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["accessors"][2]["componentType"] = 5125;
       }},
      {"matrix node", "has a matrix", [](GltfWriter& g) {
         g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
         g.doc["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
       }},
      {"negative time", "times are finite seconds >= 0", [](GltfWriter& g) { g.animate(0, "scale", "STEP", {-1, 1}, std::vector<float>(6, 1)); }},
  };
  for (const Case& c : cases) {
    hdrd::testing::TempDir dir;
    GltfWriter g;
    c.edit(g);
    auto s = load_gltf_file(g.write(dir.path(), "bad"));
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.error().code, "gltf.invalid") << c.name;
    EXPECT_NE(s.error().message.find(c.want), std::string::npos) << c.name << ": " << s.error().message;
    EXPECT_NE(s.error().message.find("animations[0]"), std::string::npos) << c.name << ": " << s.error().message;
  }
}

TEST(GltfAnimation, WeightsAreIgnoredWithAWarning) {
  hdrd::testing::TempDir dir;
  GltfWriter g;
  g.animate(0, "translation", "LINEAR", {0, 1}, std::vector<float>(6, 0));
  g.doc["animations"][0]["channels"][0]["target"]["path"] = "weights";
  auto s = load_gltf_file(g.write(dir.path(), "weights"));
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_FALSE(s->animation);  // nothing left to play: a still scene
  EXPECT_TRUE(std::any_of(s->warnings.begin(), s->warnings.end(),
                          [](const std::string& w) { return w.find("weights are not animated") != std::string::npos; }));
}

// ---- JSON keyframes -----------------------------------------------------------------------------
json keyframed_scene() {
  return {{"hdrd_scene", 1},
          {"camera", {{"position", {0, 1, 5}}, {"target", {0, 0, 0}}}},
          {"lights", {{{"type", "point"}, {"name", "lamp"}, {"position", {0, 2, 0}}, {"intensity_cd", 100}}}},
          {"materials", {{{"name", "grey"}, {"base_color", {0.5, 0.5, 0.5}}}}},
          {"objects", {{{"type", "sphere"}, {"material", "grey"}, {"radius", 0.5}}}},
          {"keyframes",
           {{"camera", {{"interpolation", "linear"},
                        {"keys", {{{"t", 0}, {"position", {0, 1, 5}}, {"yfov_deg", 40}},
                                  {{"t", 2}, {"position", {4, 1, 5}}, {"yfov_deg", 60}},
                                  {{"t", 3}, {"position", {0, 9, 9}}, {"cut", true}}}}}},
            {"lights", {{{"light", "lamp"}, {"interpolation", "step"},
                         {"keys", {{{"t", 0}, {"intensity_cd", 100}}, {{"t", 1}, {"intensity_cd", 400}, {"color", {1, 0.5, 0.25}}}}}}}},
            {"exposure", {{{"t", 0}, {"ev100", 4}, {"compensation_ev", 0}}, {{"t", 4}, {"ev100", 12}, {"compensation_ev", -1}}}}}}};
}

TEST(SceneKeyframes, CameraLightsAndExposureAreSampled) {
  auto s = parse_scene_json(keyframed_scene());
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->animation);
  EXPECT_DOUBLE_EQ(s->animation->duration_s(), 4.0);
  Scene posed = *s;
  auto f = animate(posed, *s->animation, 1.0);
  ASSERT_TRUE(f.ok());
  EXPECT_NEAR(posed.camera->position.x, 2.0, 1e-12);
  EXPECT_NEAR(posed.camera->yfov_rad, 50 * kPi / 180, 1e-12);
  EXPECT_NEAR(posed.camera->target.z, 0.0, 1e-12);  // not keyframed: the scene's own
  EXPECT_EQ(posed.lights[0].intensity_cd, 400);       // step: from t = 1
  EXPECT_EQ(posed.lights[0].color, (Vec3{1, 0.5, 0.25}));
  EXPECT_DOUBLE_EQ(*f->exposure_ev100, 4 + 8 * 0.25);
  EXPECT_DOUBLE_EQ(*f->exposure_compensation_ev, -0.25);
  EXPECT_FALSE(f->scene_cut);
  // The cut at 3 s: held at the 2 s key until then, then the new view; the frame at 3 s is a cut.
  posed = *s;
  ASSERT_TRUE(animate(posed, *s->animation, 2.9).ok());
  EXPECT_EQ(posed.camera->position, (Vec3{4, 1, 5}));
  posed = *s;
  auto cut = animate(posed, *s->animation, 3.0, 2.9);
  ASSERT_TRUE(cut.ok());
  EXPECT_TRUE(cut->scene_cut);
  EXPECT_EQ(posed.camera->position, (Vec3{0, 9, 9}));
  posed = *s;
  EXPECT_FALSE(animate(posed, *s->animation, 3.1, 3.05)->scene_cut);
  posed = *s;
  EXPECT_TRUE(animate(posed, *s->animation, 3.1, 2.95)->scene_cut);
}

TEST(SceneKeyframes, YawPitchAimsTheCamera) {
  json doc = keyframed_scene();
  doc["keyframes"] = {{"camera", {{{"t", 0}, {"yaw_deg", 90}, {"pitch_deg", 0}}, {{"t", 1}, {"yaw_deg", 180}, {"pitch_deg", 30}}}}};
  auto s = parse_scene_json(doc);
  ASSERT_TRUE(s.ok()) << s.error().message;
  Scene posed = *s;
  ASSERT_TRUE(animate(posed, *s->animation, 0).ok());
  const Vec3 d0 = posed.camera->target - posed.camera->position;
  EXPECT_NEAR(d0.x, 1, 1e-12);  // yaw 90: down +X
  ASSERT_TRUE(animate(posed, *s->animation, 1).ok());
  const Vec3 d1 = posed.camera->target - posed.camera->position;
  EXPECT_NEAR(d1.z, std::cos(30 * kPi / 180), 1e-12);  // yaw 180: down +Z, pitched up 30
  EXPECT_NEAR(d1.y, 0.5, 1e-12);
}

TEST(SceneKeyframes, BadKeyframesAreErrorsNamingTheField) {
  const struct { const char* name; json keyframes; const char* field; } cases[] = {
      {"time order", {{"camera", {{{"t", 1}, {"position", {0, 0, 1}}}, {{"t", 1}, {"position", {0, 0, 2}}}}}}, "keyframes.camera[1].t"},
      {"missing time", {{"camera", {{{"position", {0, 0, 1}}}}}}, "keyframes.camera[0].t"},
      {"infinite value", {{"exposure", {{{"t", 0}, {"ev100", std::numeric_limits<double>::infinity()}}}}}, "keyframes.exposure[0].ev100"},
      {"unknown field", {{"camera", {{{"t", 0}, {"zoom", 2}}}}}, "keyframes.camera[0].zoom"},
      {"bad interpolation", {{"camera", {{"interpolation", "bezier"}, {"keys", {{{"t", 0}}}}}}}, "keyframes.camera.interpolation"},
      {"unknown light", {{"lights", {{{"light", "sun"}, {"keys", {{{"t", 0}, {"intensity_cd", 1}}}}}}}}, "keyframes.lights[0].light"},
      {"wrong unit", {{"lights", {{{"light", 0}, {"keys", {{{"t", 0}, {"illuminance_lux", 1}}}}}}}}, "keyframes.lights[0].keys[0].illuminance_lux"},
      {"yaw without pitch", {{"camera", {{{"t", 0}, {"yaw_deg", 10}}}}}, "keyframes.camera[0].pitch_deg"},
      {"negative time", {{"camera", {{{"t", -1}}}}}, "keyframes.camera[0].t"},
      {"empty", {{"camera", json::array()}}, "keyframes.camera"},
      {"unknown track", {{"sun", json::array()}}, "keyframes.sun"},
  };
  for (const auto& c : cases) {
    json doc = keyframed_scene();
    doc["keyframes"] = c.keyframes;
    auto s = parse_scene_json(doc);
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.error().field, c.field) << c.name << ": " << s.error().message;
  }
}

// ---- Rendered frames --------------------------------------------------------------------------
constexpr int kW = 96, kH = 64;

// Luminance-weighted centroid (x) of the pixels brighter than `threshold` cd/m2.
double bright_centroid_x(const Image& img, double threshold) {
  double sum = 0, sx = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const float* p = img.rgba.data() + (static_cast<std::size_t>(y) * img.width + x) * 4;
      const double l = testing::luma(p);
      if (l > threshold) {
        sum += l;
        sx += l * (x + 0.5);
      }
    }
  return sum > 0 ? sx / sum : -1;
}

double median_luminance(const Image& img) {
  std::vector<double> l;
  for (std::size_t i = 0; i < img.pixel_count(); ++i) l.push_back(testing::luma(img.rgba.data() + i * 4));
  std::nth_element(l.begin(), l.begin() + static_cast<std::ptrdiff_t>(l.size() / 2), l.end());
  return l[l.size() / 2];
}

TEST(AnimatedRender, MovedQuadMovesItsLightByTheProjectedDistance) {
  HDRD_REQUIRE_RENDERER(renderer);
  hdrd::testing::TempDir dir;
  GltfWriter g;
  g.animate(0, "translation", "LINEAR", {0, 2}, {-1, 0, 0, 1, 0, 0});
  RenderRequest req;
  req.scene = g.write(dir.path(), "moving").string();
  req.width = kW;
  req.height = kH;
  req.camera = CameraOverride{Vec3{0, 0, 5}, Vec3{0, 0, 0}, 40.0};
  // Projected x of a point at x_m on the z = 0 plane: (x / (5 tan(fov/2) aspect) + 1) / 2 * W.
  const auto expect_px = [&](double x_m) {
    return (x_m / (5 * std::tan(20 * kPi / 180) * double(kW) / kH) + 1) / 2 * kW;
  };
  const auto loads = renderer.scene_loads();
  req.time_s = 0.5;
  auto a = renderer.render(req);
  ASSERT_TRUE(a.ok()) << a.error().message;
  req.time_s = 1.5;
  auto b = renderer.render(req);
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_DOUBLE_EQ(a->duration_s, 2.0);
  EXPECT_NEAR(bright_centroid_x(a->scene_nits, 100), expect_px(-0.5), 0.3);
  EXPECT_NEAR(bright_centroid_x(b->scene_nits, 100), expect_px(0.5), 0.3);
  // The second frame reused the loaded scene: one load for both.
  EXPECT_FALSE(a->scene_reused);
  EXPECT_TRUE(b->scene_reused);
  EXPECT_EQ(renderer.scene_loads(), loads + 1);
  // Determinism: the same time again gives the identical frame.
  req.time_s = 0.5;
  auto c = renderer.render(req);
  ASSERT_TRUE(c.ok());
  EXPECT_TRUE(c->scene_reused);
  ASSERT_EQ(c->scene_nits.rgba.size(), a->scene_nits.rgba.size());
  EXPECT_EQ(0, std::memcmp(c->scene_nits.rgba.data(), a->scene_nits.rgba.data(), a->scene_nits.rgba.size() * sizeof(float)));
  // An edited file is loaded again (its size and modification time are part of the key).
  g.animate(0, "scale", "STEP", {0, 1}, {1, 1, 1, 1, 1, 1});
  g.write(dir.path(), "moving");
  auto d = renderer.render(req);
  ASSERT_TRUE(d.ok());
  EXPECT_FALSE(d->scene_reused);
}

TEST(AnimatedRender, HdrSceneWalksOutIntoTheSunByManyStops) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest req;
  req.scene = "hdr";
  req.width = kW;
  req.height = kH;
  req.samples = 1;
  auto inside = renderer.render(req);
  ASSERT_TRUE(inside.ok()) << inside.error().message;
  EXPECT_DOUBLE_EQ(inside->duration_s, kHdrWalkOutSeconds);
  req.time_s = kHdrWalkOutSeconds;
  auto outside = renderer.render(req);
  ASSERT_TRUE(outside.ok()) << outside.error().message;
  EXPECT_TRUE(outside->scene_reused);
  const double stops = std::log2(median_luminance(outside->scene_nits) / median_luminance(inside->scene_nits));
  EXPECT_GT(stops, 8.0) << "inside " << median_luminance(inside->scene_nits) << " cd/m2, outside "
                        << median_luminance(outside->scene_nits);
  EXPECT_LT(outside->camera.position.z, -1.0);  // out through the door (the front wall is at z = -0.1)
}

TEST(AnimatedRender, JsonKeyframedExposureIsReported) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest req;
  req.scene_json = keyframed_scene();
  req.width = kW;
  req.height = kH;
  req.samples = 1;
  req.time_s = 2.0;
  auto r = renderer.render(req);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(*r->exposure_ev100, 8.0);
  EXPECT_DOUBLE_EQ(*r->exposure_compensation_ev, -0.5);
  EXPECT_DOUBLE_EQ(r->duration_s, 4.0);
  EXPECT_EQ(r->cut_times_s, std::vector<double>{3.0});
  EXPECT_NEAR(r->camera.position.x, 4.0, 1e-12);
  req.previous_time_s = 2.9;
  req.time_s = 3.0;
  auto cut = renderer.render(req);
  ASSERT_TRUE(cut.ok());
  EXPECT_TRUE(cut->scene_cut);
  // A still scene reports no exposure and no length.
  RenderRequest still;
  still.scene = "underwater";
  still.width = kW;
  still.height = kH;
  still.samples = 1;
  auto s = renderer.render(still);
  ASSERT_TRUE(s.ok());
  EXPECT_FALSE(s->exposure_ev100);
  EXPECT_EQ(s->duration_s, 0.0);
  // The furnace is still but carries its exposure: its 1000 cd/m2 is diffuse white,
  // 1 / (1.2 * 2^EV100) = 1/1000.
  RenderRequest furnace = still;
  furnace.scene = "furnace";
  auto f = renderer.render(furnace);
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->exposure_ev100);
  EXPECT_NEAR(1.0 / (1.2 * std::exp2(*f->exposure_ev100)), 1e-3, 1e-12);
  EXPECT_EQ(f->duration_s, 0.0);
  still.time_s = NAN;
  EXPECT_EQ(renderer.render(still).error().code, "render.time_s");
}

}  // namespace
}  // namespace hdrd::shading

// The JSON scene format (docs/scene-format.md): the documented example parses to what
// the document says, and every kind of bad input is an error naming its field.
#include <gtest/gtest.h>

#include <functional>

#include "shading/materials.hpp"
#include "shading/scene_loader.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

using nlohmann::json;

// The first ```json block of docs/scene-format.md.
json documented_example() {
  const std::string doc = hdrd::testing::read_file(hdrd::testing::source_dir() / "docs/scene-format.md");
  const auto start = doc.find("```json\n");
  const auto end = doc.find("```", start + 8);
  if (start == std::string::npos || end == std::string::npos) return nullptr;
  return json::parse(doc.substr(start + 8, end - start - 8));
}

json minimal() {
  return {{"hdrd_scene", 1},
          {"materials", {{{"name", "m"}}}},
          {"objects", {{{"type", "sphere"}, {"material", "m"}}}}};
}

TEST(SceneJson, DocumentedExampleParses) {
  const json doc = documented_example();
  ASSERT_TRUE(doc.is_object()) << "docs/scene-format.md has no json example";
  auto s = parse_scene_json(doc);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->name, "two spheres");
  ASSERT_EQ(s->materials.size(), 4u);
  EXPECT_EQ(s->materials[0].metallic, 1.0);  // the gold preset: metal, F0 as base colour
  EXPECT_EQ(s->materials[0].base_color, find_f0_preset("gold")->f0_air);
  EXPECT_DOUBLE_EQ(s->materials[0].roughness, 0.3);
  EXPECT_DOUBLE_EQ(s->materials[1].dielectric_f0, 0.04);  // specular 0.5
  EXPECT_EQ(s->materials[2].base_color, (Vec3{0.3, 0.3, 0.3}));
  EXPECT_EQ(s->materials[3].emissive_nits, (Vec3{2000, 1800, 1500}));
  ASSERT_EQ(s->lights.size(), 3u);
  EXPECT_EQ(s->lights[0].type, LightType::directional);
  EXPECT_DOUBLE_EQ(s->lights[0].illuminance_lux, 20000);
  EXPECT_EQ(s->lights[1].type, LightType::point);
  EXPECT_DOUBLE_EQ(s->lights[1].range_m, 10);
  EXPECT_EQ(s->lights[2].type, LightType::spot);
  EXPECT_NEAR(s->lights[2].outer_cone_rad, 30 * kPi / 180, 1e-12);
  ASSERT_EQ(s->instances.size(), 4u);
  EXPECT_EQ(s->instances[1].material, 1);
  EXPECT_EQ(s->instances[1].transform.transform_point({0, 0, 0}), (Vec3{0.7, 0.5, 0}));
  ASSERT_TRUE(s->ambient_nits.has_value());
  EXPECT_EQ(*s->ambient_nits, (Vec3{300, 330, 400}));
  ASSERT_TRUE(s->camera.has_value());
  EXPECT_NEAR(s->camera->yfov_rad, 40 * kPi / 180, 1e-12);
}

TEST(SceneJson, MeshObjectsAndTransforms) {
  json j = minimal();
  j["objects"] = {{{"type", "mesh"}, {"material", 0}, {"positions", {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}},
                   {"indices", {0, 1, 2, 2, 1, 3}}, {"uvs", {0, 0, 1, 0, 0, 1, 1, 1}},
                   {"position", {1, 2, 3}}, {"rotation_deg", {0, 90, 0}}, {"scale", 2}}};
  auto s = parse_scene_json(j);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->meshes.size(), 1u);
  EXPECT_EQ(s->meshes[0].indices.size(), 6u);
  // Normals computed from the counter-clockwise triangles: +z.
  EXPECT_NEAR(s->meshes[0].vertices[0].normal[2], 1.0, 1e-6);
  // Scale 2, then 90 degrees about y (x -> -z), then translation.
  const Vec3 p = s->instances[0].transform.transform_point({1, 0, 0});
  EXPECT_NEAR(p.x, 1, 1e-12);
  EXPECT_NEAR(p.y, 2, 1e-12);
  EXPECT_NEAR(p.z, 1, 1e-12);
}

TEST(SceneJson, MediumAndPresetsUnderWater) {
  json j = minimal();
  j["medium_ior"] = 1.33;
  j["materials"] = {{{"name", "m"}, {"preset", "iron"}}};
  auto s = parse_scene_json(j);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_DOUBLE_EQ(s->medium_ior, 1.33);
  const Vec3 water = metal_f0_in_medium(s->materials[0].base_color, s->materials[0].metal_n, 1.33);
  EXPECT_NEAR(water.x, 0.470, 1e-4);  // RTR4 table 9.4
}

struct BadCase {
  const char* name;
  std::function<void(json&)> edit;
  const char* field;  // the Error's field
};

TEST(SceneJson, BadInputNamesTheField) {
  const BadCase cases[] = {
      {"not an object", [](json& j) { j = json::array(); }, "scene"},
      {"no version", [](json& j) { j.erase("hdrd_scene"); }, "hdrd_scene"},
      {"wrong version", [](json& j) { j["hdrd_scene"] = 2; }, "hdrd_scene"},
      {"unknown top field", [](json& j) { j["lighting"] = 1; }, "lighting"},
      {"unknown material field", [](json& j) { j["materials"][0]["colour"] = 1; }, "materials[0].colour"},
      {"string for number", [](json& j) { j["materials"][0]["roughness"] = "0.5"; }, "materials[0].roughness"},
      {"out of range", [](json& j) { j["materials"][0]["metallic"] = 1.5; }, "materials[0].metallic"},
      {"huge number", [](json& j) { j["ambient_nits"] = 1e300; }, "ambient_nits"},
      {"short vector", [](json& j) { j["materials"][0]["base_color"] = {1, 1}; }, "materials[0].base_color"},
      {"null in vector", [](json& j) { j["materials"][0]["base_color"] = {1, nullptr, 1}; }, "materials[0].base_color[1]"},
      {"unknown preset", [](json& j) { j["materials"][0]["preset"] = "adamantium"; }, "materials[0].preset"},
      {"f0 and specular", [](json& j) { j["materials"][0]["f0"] = 0.04; j["materials"][0]["specular"] = 0.5; }, "materials[0].specular"},
      {"duplicate name", [](json& j) { j["materials"].push_back({{"name", "m"}}); }, "materials[1].name"},
      {"unknown material", [](json& j) { j["objects"][0]["material"] = "x"; }, "objects[0].material"},
      {"material index", [](json& j) { j["objects"][0]["material"] = 3; }, "objects[0].material"},
      {"no material", [](json& j) { j["objects"][0].erase("material"); }, "objects[0].material"},
      {"object type", [](json& j) { j["objects"][0]["type"] = "teapot"; }, "objects[0].type"},
      {"sphere field", [](json& j) { j["objects"][0]["size"] = 1; }, "objects[0].size"},
      {"sphere segments", [](json& j) { j["objects"][0]["segments"] = 100000; }, "objects[0].segments"},
      {"zero scale", [](json& j) { j["objects"][0]["scale"] = 0; }, "objects[0].scale"},
      {"light type", [](json& j) { j["lights"] = {{{"type", "area"}}}; }, "lights[0].type"},
      {"negative lux", [](json& j) { j["lights"] = {{{"type", "directional"}, {"illuminance_lux", -5}}}; }, "lights[0].illuminance_lux"},
      {"point with direction", [](json& j) { j["lights"] = {{{"type", "point"}, {"direction", {0, -1, 0}}}}; }, "lights[0].direction"},
      {"zero direction", [](json& j) { j["lights"] = {{{"type", "directional"}, {"direction", {0, 0, 0}}}}; }, "lights[0].direction"},
      {"spot cones", [](json& j) { j["lights"] = {{{"type", "spot"}, {"inner_cone_deg", 40}, {"outer_cone_deg", 30}}}; }, "lights[0].inner_cone_deg"},
      {"too many lights", [](json& j) { j["lights"] = json::array(); for (int i = 0; i < 65; ++i) j["lights"].push_back({{"type", "point"}}); }, "lights"},
      {"camera field", [](json& j) { j["camera"] = {{"fov", 40}}; }, "camera.fov"},
      {"camera at target", [](json& j) { j["camera"] = {{"position", {1, 1, 1}}, {"target", {1, 1, 1}}}; }, "camera.target"},
      {"medium", [](json& j) { j["medium_ior"] = 0.5; }, "medium_ior"},
      {"mesh index", [](json& j) { j["objects"] = {{{"type", "mesh"}, {"material", 0}, {"positions", {0, 0, 0, 1, 0, 0, 0, 1, 0}}, {"indices", {0, 1, 7}}}}; }, "objects[0].indices[2]"},
      {"mesh negative index", [](json& j) { j["objects"] = {{{"type", "mesh"}, {"material", 0}, {"positions", {0, 0, 0, 1, 0, 0, 0, 1, 0}}, {"indices", {0, 1, -2}}}}; }, "objects[0].indices[2]"},
      {"mesh length", [](json& j) { j["objects"] = {{{"type", "mesh"}, {"material", 0}, {"positions", {0, 0, 0, 1}}}}; }, "objects[0].positions"},
      {"degenerate mesh", [](json& j) { j["objects"] = {{{"type", "mesh"}, {"material", 0}, {"positions", {1, 1, 1, 1, 1, 1, 1, 1, 1}}}}; }, "meshes[0]"},
      {"gltf without path", [](json& j) { j["objects"] = {{{"type", "gltf"}}}; }, "objects[0].path"},
      {"gltf missing file", [](json& j) { j["objects"] = {{{"type", "gltf"}, {"path", "/nonexistent.glb"}}}; }, "objects[0].path"},
  };
  for (const BadCase& c : cases) {
    json j = minimal();
    c.edit(j);
    auto s = parse_scene_json(j);
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.error().field, c.field) << c.name << ": " << s.error().message;
    EXPECT_FALSE(s.error().message.empty());
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos) << "one line: " << s.error().message;
  }
}

TEST(SceneJson, EnvironmentFileAndSky) {
  SceneLoadOptions o;
  o.base_dir = "/assets/scenes";
  json j = minimal();
  j["environment"] = {{"file", "maps/studio.exr"}, {"scale", 250}, {"rotation_deg", -30}};
  auto s = parse_scene_json(j, o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->environment.has_value());
  EXPECT_EQ(s->environment->file, std::filesystem::path("/assets/scenes/maps/studio.exr"));  // next to the scene
  EXPECT_EQ(s->environment->scale, 250);
  EXPECT_EQ(s->environment->rotation_deg, -30);
  EXPECT_FALSE(s->environment->sky.has_value());
  j["environment"] = {{"file", "/abs/sky.hdr"}};
  s = parse_scene_json(j, o);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->environment->file, std::filesystem::path("/abs/sky.hdr"));
  EXPECT_EQ(s->environment->scale, 1);
  j["environment"] = {{"sky", {{"sun_elevation_deg", 12}, {"sun_azimuth_deg", 200}, {"turbidity", 4}, {"sun", false}}}};
  s = parse_scene_json(j, o);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->environment->sky.has_value());
  EXPECT_EQ(s->environment->sky->sun_elevation_deg, 12);
  EXPECT_EQ(s->environment->sky->sun_azimuth_deg, 200);
  EXPECT_EQ(s->environment->sky->turbidity, 4);
  EXPECT_EQ(s->environment->sky->ground_albedo, SkyParams{}.ground_albedo);
  EXPECT_FALSE(s->environment->sky->sun);
  j["environment"] = {{"sky", json::object()}};
  s = parse_scene_json(j, o);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->environment->sky->sun_elevation_deg, SkyParams{}.sun_elevation_deg);
}

TEST(SceneJson, BadEnvironmentNamesTheField) {
  const BadCase cases[] = {
      {"not an object", [](json& j) { j["environment"] = "sky"; }, "environment"},
      {"neither", [](json& j) { j["environment"] = {{"scale", 2}}; }, "environment"},
      {"both", [](json& j) { j["environment"] = {{"file", "a.exr"}, {"sky", json::object()}}; }, "environment"},
      {"unknown field", [](json& j) { j["environment"] = {{"file", "a.exr"}, {"intensity", 2}}; }, "environment.intensity"},
      {"empty file", [](json& j) { j["environment"] = {{"file", ""}}; }, "environment.file"},
      {"file number", [](json& j) { j["environment"] = {{"file", 3}}; }, "environment.file"},
      {"negative scale", [](json& j) { j["environment"] = {{"file", "a.exr"}, {"scale", -1}}; }, "environment.scale"},
      {"rotation", [](json& j) { j["environment"] = {{"file", "a.exr"}, {"rotation_deg", 1e6}}; }, "environment.rotation_deg"},
      {"sky field", [](json& j) { j["environment"] = {{"sky", {{"elevation", 10}}}}; }, "environment.sky.elevation"},
      {"sun below horizon", [](json& j) { j["environment"] = {{"sky", {{"sun_elevation_deg", -5}}}}; }, "environment.sky.sun_elevation_deg"},
      {"turbidity", [](json& j) { j["environment"] = {{"sky", {{"turbidity", 1}}}}; }, "environment.sky.turbidity"},
      {"albedo", [](json& j) { j["environment"] = {{"sky", {{"ground_albedo", 2}}}}; }, "environment.sky.ground_albedo"},
      {"sun flag", [](json& j) { j["environment"] = {{"sky", {{"sun", 1}}}}; }, "environment.sky.sun"},
      {"and ambient", [](json& j) { j["environment"] = {{"sky", json::object()}}; j["ambient_nits"] = 100; }, "ambient_nits"},
  };
  for (const BadCase& c : cases) {
    json j = minimal();
    c.edit(j);
    auto s = parse_scene_json(j);
    ASSERT_FALSE(s.ok()) << c.name;
    EXPECT_EQ(s.error().field, c.field) << c.name << ": " << s.error().message;
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos);
  }
  SceneLoadOptions no_files;
  no_files.allow_files = false;
  json j = minimal();
  j["environment"] = {{"file", "studio.exr"}};
  auto s = parse_scene_json(j, no_files);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "environment.file");
  EXPECT_NE(s.error().message.find("not allowed"), std::string::npos);
}

TEST(SceneJson, TriangleBudgetIsCheckedBeforeBuilding) {
  SceneLoadOptions o;
  o.limits.max_triangles = 100000;
  json j = minimal();
  j["objects"] = json::array();
  for (int i = 0; i < 10; ++i) j["objects"].push_back({{"type", "sphere"}, {"material", "m"}, {"segments", 512}});
  auto s = parse_scene_json(j, o);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "objects");
}

TEST(SceneJson, FileReferencesCanBeForbidden) {
  SceneLoadOptions o;
  o.allow_files = false;
  json j = minimal();
  j["objects"].push_back({{"type", "gltf"}, {"path", "model.glb"}});
  auto s = parse_scene_json(j, o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("not allowed"), std::string::npos) << s.error().message;
}

TEST(SceneJson, SyntaxErrorsAreReported) {
  auto s = parse_scene_json_text("{\"hdrd_scene\": 1,");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, "scene.json_syntax");
  EXPECT_FALSE(parse_scene_json_text("{\"hdrd_scene\": 1, \"ambient_nits\": NaN}").ok());
}

// Issue 14: scene_json_fuzz aborted on 5e551, the JSON library's exception escaping a
// function that returns a Result. Now an error naming the field.
TEST(SceneJson, NumberOverflowNamesTheField) {
  auto s = parse_scene_json_text(R"({"hdrd_scene": 1, "lights": [{"type": "sun", "illuminance_lux": 5e551}]})");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, "scene.json_value");
  EXPECT_EQ(s.error().field, "lights[0].illuminance_lux");
  EXPECT_EQ(s.error().message.find("json.exception"), std::string::npos) << s.error().message;
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  s = parse_scene_json_text(R"({"hdrd_scene": 1, "x": )" + deep + "}");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, "scene.json_depth");
}

TEST(SceneJson, BuiltinsAndDefault) {
  EXPECT_EQ(default_scene_name(), "material-grid");
  for (const std::string& name : builtin_scene_names()) {
    auto s = make_builtin_scene(name);
    ASSERT_TRUE(s.ok()) << name;
    EXPECT_TRUE(validate(*s).ok()) << name;
    EXPECT_EQ(s->name, name);
  }
  for (const char* name : {"material-grid", "fresnel", "furnace", "hdr", "underwater"}) EXPECT_TRUE(is_builtin_scene(name));
  auto s = load_scene("nope");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().field, "scene");
  EXPECT_DOUBLE_EQ(make_builtin_scene("underwater")->medium_ior, kWaterIor);
}

}  // namespace
}  // namespace hdrd::shading

// glTF 2.0 loading and rendering against the Khronos sample models in
// ../shared/fixtures/gltf (their published expectations), and malformed glTF input.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <map>
#include <numeric>

#include "shading/gltf_internal.hpp"
#include "shading/shapes.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::shading {
namespace {

using testing::luma;
using testing::pixel_ray;

// Pixel of a world point (rows top-down), for the renderer's projection.
std::pair<int, int> project(const Camera& c, int w, int h, Vec3 p) {
  const Vec3 v = look_at(c.position, c.target, c.up).transform_point(p);
  const double t = std::tan(c.yfov_rad / 2), aspect = double(w) / h;
  const double x = v.x / (-v.z * t * aspect), y = v.y / (-v.z * t);
  return {static_cast<int>((x + 1) / 2 * w), static_cast<int>((1 - y) / 2 * h)};
}

// A JSON scene that imports a fixture with no lights: only emission is left.
nlohmann::json emission_only(const std::filesystem::path& gltf, Vec3 eye, Vec3 target) {
  return {{"hdrd_scene", 1},
          {"camera", {{"position", {eye.x, eye.y, eye.z}}, {"target", {target.x, target.y, target.z}}, {"yfov_deg", 40}}},
          {"lights", nlohmann::json::array()},
          {"objects", {{{"type", "gltf"}, {"path", gltf.string()}}}}};
}

TEST(Gltf, MetalRoughSpheresLoadsAsGltfAndGlb) {
  HDRD_REQUIRE_FIXTURE(glb, "fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb");
  HDRD_REQUIRE_FIXTURE(gltf, "fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf");
  auto a = load_gltf_file(glb);
  auto b = load_gltf_file(gltf);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(a->instances.size(), b->instances.size());
  EXPECT_EQ(std::count_if(a->materials.begin(), a->materials.end(),
                          [](const Material& m) { return m.name.rfind("mat_", 0) == 0; }),
            98);
  // mat_1: metallic 0, roughness 1/6, base 0.6038 (the file's values).
  EXPECT_EQ(a->materials[1].name, "mat_1");
  EXPECT_NEAR(a->materials[1].roughness, 0.1666666716337204, 1e-9);
  EXPECT_NEAR(a->materials[1].base_color.x, 0.6038269996643066, 1e-9);
  EXPECT_EQ(a->materials[1].metallic, 0.0);
  // No lights and no camera in the file: the default rig, and the warnings say so.
  ASSERT_EQ(a->lights.size(), 1u);
  EXPECT_FALSE(a->camera.has_value());
  const auto has = [&](const std::string& w) {
    return std::any_of(a->warnings.begin(), a->warnings.end(), [&](const std::string& s) { return s.find(w) != std::string::npos; });
  };
  EXPECT_TRUE(has("no lights: added a default rig"));
  EXPECT_TRUE(has("no camera"));
}

TEST(Gltf, TextureEncodingDecodesSrgb136To0_2462) {
  HDRD_REQUIRE_FIXTURE(path, "fixtures/gltf/TextureEncodingTest/TextureEncodingTest.glb");
  HDRD_REQUIRE_RENDERER(renderer);
  // Emission row: material 4 has emissiveFactor 0.24620132670783548, materials 5-7 an
  // emissive texture of 136/255 in three PNG flavours; decoded as sRGB they must agree
  // (times kGltfEmissiveNits, the luminance of an emissive 1.0).
  auto scene = load_gltf_file(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  std::vector<Vec3> centres;  // where the file puts the emissive spheres
  for (const Instance& inst : scene->instances) {
    if (inst.material < 4 || inst.material > 7) continue;
    Bounds b;
    for (const Vertex& v : scene->meshes[inst.mesh].vertices) {
      const Vec3 p = inst.transform.transform_point({v.position[0], v.position[1], v.position[2]});
      b.min = b.empty ? p : vmin(b.min, p);
      b.max = b.empty ? p : vmax(b.max, p);
      b.empty = false;
    }
    centres.push_back({b.center().x, b.center().y, b.max.z});
  }
  ASSERT_EQ(centres.size(), 4u);
  const Vec3 mid = (centres.front() + centres.back()) * 0.5;
  RenderRequest q;
  q.scene_json = emission_only(path, mid + Vec3{0, 0, 12}, mid);
  q.width = 200;
  q.height = 100;
  q.samples = 1;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (const Vec3& c : centres) {
    const auto [px, py] = project(r->camera, q.width, q.height, c);
    const float* p = r->scene_nits.px(px, py);
    EXPECT_NEAR(p[1] / kGltfEmissiveNits, 0.2462013267, 1e-4) << "sphere at x = " << c.x;
    EXPECT_NEAR(p[0], 0.0, 1e-6);
    EXPECT_NEAR(p[2], 0.0, 1e-6);
  }
  // The decoded texels themselves: 136 in the green channel of all three images.
  for (int m = 5; m <= 7; ++m) {
    const TextureRef& t = scene->materials[m].emissive_texture;
    ASSERT_TRUE(t);
    EXPECT_EQ(scene->textures[t.index].rgba8[1], 136);
  }
}

TEST(Gltf, EmissiveStrengthScalesEmission1To16) {
  HDRD_REQUIRE_FIXTURE(path, "fixtures/gltf/EmissiveStrengthTest/EmissiveStrengthTest.glb");
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene_json = emission_only(path, {0, 0, 14}, {0, 0, 0});
  q.width = 240;
  q.height = 80;
  q.samples = 1;
  auto r = renderer.render(q);
  ASSERT_TRUE(r.ok()) << r.error().message;
  // Cube1..Cube16 at x = -6, -3, 0, 3, 6 (file nodes); emissiveFactor (0.1, 0.5, 0.9) x strength
  // x kGltfEmissiveNits.
  const double strength[] = {1, 2, 4, 8, 16};
  for (int i = 0; i < 5; ++i) {
    const auto [px, py] = project(r->camera, q.width, q.height, {-6.0 + 3 * i, 0, 0.5});
    const float* p = r->scene_nits.px(px, py);
    EXPECT_NEAR(p[0] / kGltfEmissiveNits, 0.1 * strength[i], 1e-5 * strength[i]) << "Cube" << strength[i];
    EXPECT_NEAR(p[1] / kGltfEmissiveNits, 0.5 * strength[i], 1e-5 * strength[i]);
    EXPECT_NEAR(p[2] / kGltfEmissiveNits, 0.9 * strength[i], 1e-5 * strength[i]);
  }
}

TEST(Gltf, NormalTangentTestGeneratesGltfTangentFrames) {
  HDRD_REQUIRE_FIXTURE(path, "fixtures/gltf/NormalTangentTest/NormalTangentTest.glb");
  auto s = load_gltf_file(path);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(s->meshes.size(), 1u);
  // The file has no TANGENT: ours must follow glTF's convention, t along +u and
  // cross(n, t) * w toward the texture's top (-v).
  const Mesh& m = s->meshes[0];
  int checked = 0;
  for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3) {
    const Vertex &a = m.vertices[m.indices[i]], &b = m.vertices[m.indices[i + 1]], &c = m.vertices[m.indices[i + 2]];
    const Vec3 e1{b.position[0] - a.position[0], b.position[1] - a.position[1], b.position[2] - a.position[2]};
    const Vec3 e2{c.position[0] - a.position[0], c.position[1] - a.position[1], c.position[2] - a.position[2]};
    const double du1 = b.uv[0] - a.uv[0], dv1 = b.uv[1] - a.uv[1], du2 = c.uv[0] - a.uv[0], dv2 = c.uv[1] - a.uv[1];
    const double det = du1 * dv2 - du2 * dv1;
    if (std::abs(det) < 1e-12) continue;
    const Vec3 dpdu = (e1 * dv2 - e2 * dv1) / det, dpdv = (e2 * du1 - e1 * du2) / det;
    const Vec3 n{a.normal[0], a.normal[1], a.normal[2]}, t{a.tangent[0], a.tangent[1], a.tangent[2]};
    EXPECT_GT(dot(t, dpdu), 0) << "triangle " << i / 3;
    EXPECT_LT(dot(cross(n, t) * a.tangent[3], dpdv), 0) << "triangle " << i / 3;
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

TEST(Gltf, NormalTangentTestNormalMapsLightLikeTheGeometry) {
  HDRD_REQUIRE_FIXTURE(path, "fixtures/gltf/NormalTangentTest/NormalTangentTest.glb");
  HDRD_REQUIRE_RENDERER(renderer);
  // Each pair: a hemisphere modelled as geometry (left) and the same bump as a normal
  // map on a flat tile (right). With generated tangents both must look lit from where
  // the light is (upper left): the brightness centroid of every tile moves up and left.
  auto scene = load_gltf_file(path);
  ASSERT_TRUE(scene.ok());
  const Mesh& m = scene->meshes[0];
  std::vector<int> parent(m.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> find = [&](int x) { return parent[x] == x ? x : parent[x] = find(parent[x]); };
  for (std::size_t i = 0; i < m.indices.size(); i += 3)
    for (int k = 1; k < 3; ++k) parent[find(m.indices[i + k])] = find(m.indices[i]);
  std::map<int, Bounds> tiles;
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    Bounds& b = tiles[find(static_cast<int>(i))];
    const auto& q = m.vertices[i].position;
    const Vec3 p = scene->instances[0].transform.transform_point({q[0], q[1], q[2]});
    b.min = b.empty ? p : vmin(b.min, p);
    b.max = b.empty ? p : vmax(b.max, p);
    b.empty = false;
  }
  Scene& s = *scene;
  s.lights.clear();
  Light key;
  key.direction = normalize(Vec3{0.6, -0.6, -0.5});  // travelling right, down, away: from the upper left
  key.illuminance_lux = 1000;
  key.cast_shadows = false;
  s.lights.push_back(key);
  s.ambient_nits.reset();
  const Bounds all = world_bounds(s);
  s.camera = Camera{all.center() + Vec3{0, 0, 3.2 * all.radius()}, all.center(), {0, 1, 0}, 40 * kPi / 180};
  RenderSettings rs;
  rs.width = 320;
  rs.height = 320;
  rs.samples = 1;
  auto r = renderer.render(s, rs);
  ASSERT_TRUE(r.ok()) << r.error().message;
  int geometry = 0, mapped = 0;
  for (const auto& [id, b] : tiles) {
    const Vec3 size = b.max - b.min;
    if (size.x < 0.05 * all.radius() || std::abs(size.x - size.y) > 0.1 * size.x) continue;  // square tiles only
    double sum = 0, cx = 0, cy = 0;
    int n = 0;
    for (double fy = 0.1; fy < 0.91; fy += 0.04)
      for (double fx = 0.1; fx < 0.91; fx += 0.04) {
        const auto px = project(*s.camera, rs.width, rs.height, {b.min.x + size.x * fx, b.min.y + size.y * fy, b.min.z});
        const double l = luma(r->scene_nits.px(px.first, px.second));
        sum += l;
        cx += l * (fx - 0.5);
        cy += l * (fy - 0.5);
        ++n;
      }
    if (sum / n < 5.0) continue;  // the metallic column: only a glint or two, no diffuse shading
    const bool is_geometry = size.z > 0.01;
    EXPECT_LT(cx / sum, -0.02) << (is_geometry ? "geometry" : "normal-mapped") << " tile at " << b.min.x << "," << b.min.y;
    EXPECT_GT(cy / sum, 0.02) << (is_geometry ? "geometry" : "normal-mapped") << " tile at " << b.min.x << "," << b.min.y;
    (is_geometry ? geometry : mapped)++;
  }
  EXPECT_GE(geometry, 10);
  EXPECT_GE(mapped, 10);
}

// A binary glTF (GLB 2) of a JSON chunk and a BIN chunk, each padded to 4 bytes.
std::string glb(std::string json, std::string bin) {
  json.resize((json.size() + 3) / 4 * 4, ' ');
  bin.resize((bin.size() + 3) / 4 * 4, '\0');
  auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };  // little-endian host
  return "glTF" + u32(2) + u32(static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size())) +
         u32(static_cast<std::uint32_t>(json.size())) + "JSON" + json + u32(static_cast<std::uint32_t>(bin.size())) +
         std::string("BIN\0", 4) + bin;
}

TEST(Gltf, MalformedInputGivesClearErrors) {
  const auto load = [](std::string_view text) {
    return load_gltf_memory({reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}, "", SceneLoadOptions{});
  };
  EXPECT_FALSE(load("").ok());
  EXPECT_FALSE(load("{").ok());
  EXPECT_FALSE(load("glTF\x02\0\0\0\xff\xff\xff\x7f").ok());  // GLB header, absurd length
  auto r = load(R"({"asset":{"version":"2.0"}})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no triangle meshes"), std::string::npos) << r.error().message;
  // An accessor that reads past its buffer.
  r = load(R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA"}],
    "bufferViews":[{"buffer":0,"byteLength":12}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("past the end"), std::string::npos) << r.error().message;
  // Three identical vertices: a degenerate mesh.
  r = load(R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AACAPwAAAEAAAEBAAACAPwAAAEAAAEBAAACAPwAAAEAAAEBA"}],
    "bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("non-degenerate"), std::string::npos) << r.error().message;
  // A buffer view past the end of its buffer (tinygltf 2.7.0 would hand it to stb_image).
  r = load(R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA"}],
    "bufferViews":[{"buffer":0,"byteOffset":8,"byteLength":8}],"images":[{"bufferView":0,"mimeType":"image/png"}]})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("outside buffer 0"), std::string::npos) << r.error().message;
  // The same in a GLB, whose buffer 0 is the binary chunk (the form fuzzing found it in).
  r = load(glb(R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12}],
    "bufferViews":[{"buffer":0,"byteOffset":8,"byteLength":8}],"images":[{"bufferView":0,"mimeType":"image/png"}]})",
               std::string(12, '\0')));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("outside buffer 0"), std::string::npos) << r.error().message;
  // A node cycle.
  r = load(R"({"asset":{"version":"2.0"},"nodes":[{"children":[1]},{"children":[0]}],"scenes":[{"nodes":[0]}]})");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cycle"), std::string::npos) << r.error().message;
}

// Issue 14: "extras" nested 20 000 arrays deep overflowed the stack in tinygltf's
// recursive value conversion. The text is refused, bounded, before tinygltf sees it; a
// NUL byte (which would end nlohmann's input early) and a number beyond double's range too.
TEST(Gltf, DeepOrBrokenJsonIsRefusedBeforeTinygltf) {
  const auto load = [](std::string_view text) {
    return load_gltf_memory({reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}, "", SceneLoadOptions{});
  };
  const std::string deep = std::string(20000, '[') + std::string(20000, ']');
  auto r = load(R"({"asset":{"version":"2.0"},"extras":)" + deep + "}");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "gltf.json_depth");
  EXPECT_NE(r.error().message.find("extras"), std::string::npos) << r.error().message;
  r = load(glb(R"({"asset":{"version":"2.0"},"extras":)" + deep + "}", ""));
  ASSERT_FALSE(r.ok()) << "the JSON chunk of a GLB as well";
  EXPECT_EQ(r.error().code, "gltf.json_depth");
  r = load(std::string(R"({"asset":{"version":"2.0"}})") + '\0' + "{}");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "gltf.json_syntax");
  r = load(R"({"asset":{"version":"2.0"},"nodes":[{"translation":[1e999,0,0]}]})");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "gltf.json_value");
  EXPECT_EQ(r.error().field, "nodes[0].translation[0]");
}

TEST(Gltf, MissingFilesGiveClearErrors) {
  HDRD_REQUIRE_FIXTURE(gltf, "fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf");
  hdrd::testing::TempDir dir;
  // The .gltf without its .bin next to it.
  std::filesystem::copy_file(gltf, dir / "spheres.gltf");
  auto r = load_gltf_file(dir / "spheres.gltf");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("spheres.gltf"), std::string::npos) << r.error().message;
  // A material whose base colour texture points at a missing PNG.
  std::ofstream(dir / "tex.gltf") << R"({"asset":{"version":"2.0"},
    "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],
    "images":[{"uri":"missing.png"}],"textures":[{"source":0}],
    "materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})";
  r = load_gltf_file(dir / "tex.gltf");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("missing"), std::string::npos) << r.error().message;
  // Confined loading refuses files outside the scene's directory.
  std::filesystem::create_directories(dir / "sub");
  std::ofstream(dir / "sub" / "escape.gltf") << R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"../secret.bin"}]})";
  std::ofstream(dir / "secret.bin") << std::string(36, '\0');
  SceneLoadOptions confined;
  confined.allow_files = false;
  r = load_gltf_file(dir / "sub" / "escape.gltf", confined);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("secret.bin"), std::string::npos) << r.error().message;
  confined.allow_files = true;  // the same file loads its buffer when allowed
  r = load_gltf_file(dir / "sub" / "escape.gltf", confined);
  ASSERT_FALSE(r.ok());  // (it has no meshes; what matters is that the buffer was read)
  EXPECT_NE(r.error().message.find("no triangle meshes"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace hdrd::shading

// glTF 2.0 through tinygltf (Debian's shared libtinygltf: <tiny_gltf.h> without
// TINYGLTF_IMPLEMENTATION). tinygltf checks the JSON and the GLB container; everything
// it hands back (indices into arrays, accessor ranges, image sizes) is checked again
// here before use, because tinygltf does not promise it.
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <set>

#include <fmt/format.h>

#include "encode/io/json_text.hpp"
#include "shading/animation.hpp"
#include "shading/gltf_internal.hpp"
#include "shading/shapes.hpp"

namespace hdrd::shading {
namespace {

constexpr std::uint64_t kMaxFileBytes = 1ULL << 30;  // tinygltf takes an unsigned int length
constexpr std::size_t kMaxAccessorCount = 1u << 26;
constexpr int kMaxNodeDepth = 128;
// Keyframe values of all animations together (doubles on the CPU: 128 MiB at most).
constexpr std::size_t kMaxAnimationValues = 1u << 24;
// glTF's own structure nests six levels (materials[i].pbrMetallicRoughness.baseColorTexture
// .extensions.KHR_texture_transform.offset); "extras" may add some.
constexpr int kMaxJsonDepth = 64;

Error gltf_error(std::string what) { return make_error("gltf.invalid", std::move(what)); }

template <class T>
bool in_range(int i, const std::vector<T>& v) {
  return i >= 0 && static_cast<std::size_t>(i) < v.size();
}

// ---- Images: size guard before stb_image decodes -------------------------------------------
std::optional<std::pair<std::uint32_t, std::uint32_t>> png_size(const unsigned char* b, int n) {
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (n < 24 || std::memcmp(b, sig, 8) != 0) return std::nullopt;
  auto be32 = [&](int o) { return (std::uint32_t(b[o]) << 24) | (b[o + 1] << 16) | (b[o + 2] << 8) | b[o + 3]; };
  return std::make_pair(be32(16), be32(20));
}

std::optional<std::pair<std::uint32_t, std::uint32_t>> jpeg_size(const unsigned char* b, int n) {
  if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return std::nullopt;
  for (int i = 2; i + 9 < n;) {
    if (b[i] != 0xFF) return std::nullopt;
    const int marker = b[i + 1];
    const int len = (b[i + 2] << 8) | b[i + 3];
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) return std::make_pair(std::uint32_t((b[i + 7] << 8) | b[i + 8]), std::uint32_t((b[i + 5] << 8) | b[i + 6]));
    if (len < 2) return std::nullopt;
    i += 2 + len;
  }
  return std::nullopt;
}

bool guarded_image_loader(tinygltf::Image* image, const int index, std::string* err, std::string* warn, int req_w,
                          int req_h, const unsigned char* bytes, int size, void* user) {
  auto dims = png_size(bytes, size);
  if (!dims) dims = jpeg_size(bytes, size);
  if (!dims) {
    if (err) *err += fmt::format("image[{}]: not a PNG or JPEG image\n", index);
    return false;
  }
  const auto [w, h] = *dims;
  if (w == 0 || h == 0 || w > 16384 || h > 16384 || std::uint64_t(w) * h > (1ULL << 26)) {
    if (err) *err += fmt::format("image[{}]: size {}x{} is outside the limits (16384 per side, 64 Mpx)\n", index, w, h);
    return false;
  }
  return tinygltf::LoadImageData(image, index, err, warn, req_w, req_h, bytes, size, user);
}

// Confined file access (SceneLoadOptions::allow_files = false): only files inside the
// glTF's own directory, opened through the scene's InputFiles. user_data points at this.
struct Confinement {
  std::filesystem::path dir;  // canonical
  const io::InputFiles* files = nullptr;
};
bool confined(const std::string& path, void* user) {
  if (!user) return false;
  const auto& root = static_cast<const Confinement*>(user)->dir;
  std::error_code ec;
  const auto p = std::filesystem::weakly_canonical(path, ec);
  if (ec || root.empty()) return false;
  const auto rel = p.lexically_relative(root);
  return !rel.empty() && *rel.begin() != "..";
}
bool confined_exists(const std::string& path, void* user) { return confined(path, user) && tinygltf::FileExists(path, nullptr); }
std::string no_expand(const std::string& p, void*) { return p; }
// Unconfined (the CLI): any file, still through InputFiles, so a FIFO is refused, not waited on.
bool plain_exists(const std::string& path, void*) { return tinygltf::FileExists(path, nullptr); }
bool plain_read(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  auto bytes = static_cast<const Confinement*>(user)->files->read(path, kMaxFileBytes);
  if (!bytes) {
    if (err) *err += one_line(bytes.error().message) + "\n";
    return false;
  }
  out->assign(bytes->begin(), bytes->end());
  return true;
}
bool confined_read(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  if (!confined(path, user)) {
    if (err) *err += "external file '" + path + "' refused: outside the scene's directory\n";
    return false;
  }
  return plain_read(out, err, path, user);
}
bool no_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) { return false; }

// ---- Checks tinygltf 2.7.0 skips ----------------------------------------------------------
// It hands an image's bufferView to the image decoder without checking that the view
// lies inside its buffer: a view past the end of a shorter buffer made stb_image read
// past the heap block (found by tests/fuzz/gltf_fuzz.cpp; the .gltf and .glb forms are
// cases of Gltf.MalformedInputGivesClearErrors). So bufferView ranges are checked against the
// buffers' byteLength (which tinygltf does enforce on the data) before it runs.
std::optional<std::string_view> gltf_json_text(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), "glTF", 4) != 0)
    return std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (bytes.size() < 20) return std::nullopt;
  std::uint32_t json_len = 0;
  std::memcpy(&json_len, bytes.data() + 12, 4);
  if (std::memcmp(bytes.data() + 16, "JSON", 4) != 0 || json_len > bytes.size() - 20) return std::nullopt;
  return std::string_view(reinterpret_cast<const char*>(bytes.data()) + 20, json_len);
}

// The JSON is read here first, bounded (tinygltf converts "extras" into its own values
// with one recursive call per level: 20 000 nested arrays overflowed the stack), so that
// no text tinygltf sees is deeper than kMaxJsonDepth, has a NUL byte (which would end it
// early) or a number beyond double's range.
Result<void> check_json_and_buffer_views(std::span<const std::uint8_t> bytes) {
  const auto text = gltf_json_text(bytes);
  if (!text) return {};  // a broken GLB container: tinygltf reports it
  auto parsed = io::parse_json_bounded(*text, io::JsonBounds{kMaxFileBytes, kMaxJsonDepth, "glTF", "gltf.json_"});
  if (!parsed) return parsed.error();
  const nlohmann::json& j = *parsed;
  if (!j.is_object()) return gltf_error("the glTF JSON is not an object");
  const auto length = [](const nlohmann::json& o, const char* key) -> std::optional<std::uint64_t> {
    const auto it = o.find(key);
    if (it == o.end()) return std::uint64_t{0};
    if (!it->is_number_unsigned()) return std::nullopt;
    return it->get<std::uint64_t>();
  };
  std::vector<std::uint64_t> buffers;
  if (const auto b = j.find("buffers"); b != j.end() && b->is_array())
    for (const auto& e : *b) {
      const auto n = e.is_object() ? length(e, "byteLength") : std::nullopt;
      if (!n) return gltf_error("buffers: byteLength must be a non-negative integer");
      buffers.push_back(*n);
    }
  const auto views = j.find("bufferViews");
  if (views == j.end() || !views->is_array()) return {};
  for (std::size_t i = 0; i < views->size(); ++i) {
    const auto& v = (*views)[i];
    const auto buffer = v.is_object() ? v.find("buffer") : v.end();
    const auto offset = v.is_object() ? length(v, "byteOffset") : std::nullopt;
    const auto size = v.is_object() ? length(v, "byteLength") : std::nullopt;
    if (!v.is_object() || buffer == v.end() || !buffer->is_number_unsigned() || !offset || !size ||
        buffer->get<std::uint64_t>() >= buffers.size())
      return gltf_error(fmt::format("bufferViews[{}]: needs a valid buffer, byteOffset and byteLength", i));
    if (*offset > buffers[buffer->get<std::uint64_t>()] || *size > buffers[buffer->get<std::uint64_t>()] - *offset)
      return gltf_error(fmt::format("bufferViews[{}]: bytes {}..{} lie outside buffer {} ({} bytes)", i, *offset,
                                    *offset + *size, buffer->get<std::uint64_t>(), buffers[buffer->get<std::uint64_t>()]));
  }
  return {};
}

// ---- Accessors ---------------------------------------------------------------------------------
struct AccessorView {
  const unsigned char* data = nullptr;  // null: all zeros (accessor without a buffer view)
  std::size_t stride = 0, count = 0;
  int component_type = 0, components = 0;
  bool normalized = false;
};

Result<AccessorView> view_accessor(const tinygltf::Model& m, int index, std::string_view what) {
  if (!in_range(index, m.accessors)) return gltf_error(fmt::format("{}: accessor {} does not exist", what, index));
  const tinygltf::Accessor& a = m.accessors[index];
  const std::string name = fmt::format("{} (accessor {})", what, index);
  if (a.sparse.isSparse) return gltf_error(name + ": sparse accessors are not supported");
  const int csize = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType));
  const int ncomp = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
  if (csize <= 0 || ncomp <= 0) return gltf_error(name + ": bad component type");
  if (a.count == 0 || a.count > kMaxAccessorCount) return gltf_error(fmt::format("{}: count {} is out of range", name, a.count));
  AccessorView v;
  v.count = a.count;
  v.component_type = a.componentType;
  v.components = ncomp;
  v.normalized = a.normalized;
  const std::size_t elem = static_cast<std::size_t>(csize) * ncomp;
  if (a.bufferView < 0) {
    v.stride = elem;
    return v;  // glTF: zeros
  }
  if (!in_range(a.bufferView, m.bufferViews)) return gltf_error(name + ": buffer view does not exist");
  const tinygltf::BufferView& bv = m.bufferViews[a.bufferView];
  if (!in_range(bv.buffer, m.buffers)) return gltf_error(name + ": buffer does not exist");
  const auto& buf = m.buffers[bv.buffer].data;
  v.stride = bv.byteStride ? bv.byteStride : elem;
  if (v.stride < elem || v.stride > 256) return gltf_error(name + ": bad byte stride");
  // All in 64 bits: offsets and lengths come straight from the file.
  const std::uint64_t end = std::uint64_t(a.byteOffset) + std::uint64_t(v.stride) * (a.count - 1) + elem;
  if (bv.byteOffset > buf.size() || bv.byteLength > buf.size() - bv.byteOffset || end > bv.byteLength)
    return gltf_error(name + ": reads past the end of its buffer");
  v.data = buf.data() + bv.byteOffset + a.byteOffset;
  return v;
}

double read_component(const AccessorView& v, std::size_t i, int c) {
  if (!v.data) return 0.0;
  const unsigned char* p = v.data + i * v.stride;
  switch (v.component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p + 4 * c, 4); return f; }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: { const double x = p[c]; return v.normalized ? x / 255.0 : x; }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const double x = static_cast<std::int8_t>(p[c]);
      return v.normalized ? std::max(x / 127.0, -1.0) : x;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      std::uint16_t s; std::memcpy(&s, p + 2 * c, 2);
      return v.normalized ? s / 65535.0 : s;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      std::int16_t s; std::memcpy(&s, p + 2 * c, 2);
      return v.normalized ? std::max(s / 32767.0, -1.0) : s;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, p + 4 * c, 4); return u; }
    default: return 0.0;
  }
}

// A float attribute of `components` per element (POSITION 3, NORMAL 3, TANGENT 4, TEXCOORD 2).
Result<AccessorView> attribute(const tinygltf::Model& m, const tinygltf::Primitive& prim, const char* name,
                               int components, std::size_t expect_count) {
  auto v = view_accessor(m, prim.attributes.at(name), name);
  if (!v) return v;
  if (v->components != components) return gltf_error(fmt::format("{} has {} components, not {}", name, v->components, components));
  if (expect_count && v->count != expect_count)
    return gltf_error(fmt::format("{} has {} elements, POSITION {}", name, v->count, expect_count));
  return v;
}

// ---- Meshes ------------------------------------------------------------------------------------------
Result<std::vector<std::uint32_t>> triangle_indices(const tinygltf::Model& m, const tinygltf::Primitive& p,
                                                    std::size_t vertex_count) {
  std::vector<std::uint32_t> raw;
  if (p.indices >= 0) {
    auto v = view_accessor(m, p.indices, "indices");
    if (!v) return v.error();
    if (v->components != 1 || v->component_type == TINYGLTF_COMPONENT_TYPE_FLOAT)
      return gltf_error("indices must be unsigned integer scalars");
    raw.reserve(v->count);
    for (std::size_t i = 0; i < v->count; ++i) {
      const double k = read_component(*v, i, 0);
      if (k >= double(vertex_count)) return gltf_error(fmt::format("index {} >= vertex count {}", k, vertex_count));
      raw.push_back(static_cast<std::uint32_t>(k));
    }
  } else {
    for (std::size_t i = 0; i < vertex_count; ++i) raw.push_back(static_cast<std::uint32_t>(i));
  }
  const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
  std::vector<std::uint32_t> tri;
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    tri.assign(raw.begin(), raw.end() - static_cast<std::ptrdiff_t>(raw.size() % 3));
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (std::size_t i = 2; i < raw.size(); ++i)
      (i % 2) ? tri.insert(tri.end(), {raw[i - 1], raw[i - 2], raw[i]}) : tri.insert(tri.end(), {raw[i - 2], raw[i - 1], raw[i]});
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (std::size_t i = 2; i < raw.size(); ++i) tri.insert(tri.end(), {raw[0], raw[i - 1], raw[i]});
  }
  return tri;
}

Result<Mesh> convert_primitive(const tinygltf::Model& m, const tinygltf::Primitive& p, const std::string& name,
                               bool needs_tangents, std::vector<std::string>& warnings) {
  if (!p.attributes.count("POSITION")) return gltf_error(name + ": primitive has no POSITION");
  auto pos = attribute(m, p, "POSITION", 3, 0);
  if (!pos) return pos.error();
  if (pos->component_type != TINYGLTF_COMPONENT_TYPE_FLOAT) return gltf_error(name + ": POSITION must be float");
  Mesh mesh;
  mesh.name = name;
  mesh.vertices.resize(pos->count);
  for (std::size_t i = 0; i < pos->count; ++i)
    for (int c = 0; c < 3; ++c) mesh.vertices[i].position[c] = float(read_component(*pos, i, c));
  const bool has_normals = p.attributes.count("NORMAL") > 0;
  const bool has_tangents = p.attributes.count("TANGENT") > 0;
  const struct { const char* name; int comps; bool present; } attrs[] = {
      {"NORMAL", 3, has_normals}, {"TANGENT", 4, has_tangents}, {"TEXCOORD_0", 2, p.attributes.count("TEXCOORD_0") > 0}};
  for (const auto& a : attrs) {
    if (!a.present) continue;
    auto v = attribute(m, p, a.name, a.comps, pos->count);
    if (!v) return make_error("gltf.invalid", name + ": " + v.error().message);
    for (std::size_t i = 0; i < v->count; ++i)
      for (int c = 0; c < a.comps; ++c) {
        const float x = float(read_component(*v, i, c));
        if (a.comps == 3) mesh.vertices[i].normal[c] = x;
        else if (a.comps == 4) mesh.vertices[i].tangent[c] = x;
        else mesh.vertices[i].uv[c] = x;
      }
  }
  if (p.attributes.count("COLOR_0")) warnings.push_back(name + ": vertex colours (COLOR_0) are ignored");
  auto idx = triangle_indices(m, p, pos->count);
  if (!idx) return make_error("gltf.invalid", name + ": " + idx.error().message);
  mesh.indices = std::move(*idx);
  if (!has_normals) compute_normals(mesh);  // glTF: flat normals; smooth ones are close enough here
  if (needs_tangents && !has_tangents) compute_tangents(mesh);
  return mesh;
}

// ---- Materials and textures --------------------------------------------------------------------
struct Loader {
  const tinygltf::Model& m;
  const SceneLoadOptions& options;
  Scene s;
  std::map<int, int> texture_map;                 // glTF texture -> scene texture
  std::map<std::pair<int, int>, std::pair<int, int>> primitives;  // (mesh, prim) -> (scene mesh, material)
  int default_material = -1;
  std::vector<AnimatedNode> graph;  // every visited node, parents first
  std::size_t animation_values = 0;

  Result<TextureRef> texture(int index, int tex_coord, double scale, const std::string& what) {
    if (index < 0) return TextureRef{};
    if (tex_coord != 0) s.warnings.push_back(what + ": only TEXCOORD_0 is supported; using it");
    if (auto it = texture_map.find(index); it != texture_map.end()) return TextureRef{it->second, scale};
    if (!in_range(index, m.textures)) return gltf_error(fmt::format("{}: texture {} does not exist", what, index));
    const tinygltf::Texture& t = m.textures[index];
    if (!in_range(t.source, m.images)) return gltf_error(fmt::format("{}: texture {} has no image", what, index));
    const tinygltf::Image& img = m.images[t.source];
    const std::string label = img.uri.empty() ? fmt::format("image {}", t.source) : "'" + img.uri + "'";
    if (img.width <= 0 || img.height <= 0 || img.image.empty())
      return gltf_error(fmt::format("{}: {} could not be loaded (missing or unreadable file?)", what, label));
    Texture out;
    out.name = img.name.empty() ? img.uri : img.name;
    out.width = img.width;
    out.height = img.height;
    if (auto e = to_rgba8(img, out, label); !e) return e.error();
    if (in_range(t.sampler, m.samplers)) {
      const tinygltf::Sampler& smp = m.samplers[t.sampler];
      auto wrap = [](int w) {
        return w == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE ? Wrap::clamp
               : w == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? Wrap::mirror : Wrap::repeat;
      };
      out.wrap_s = wrap(smp.wrapS);
      out.wrap_t = wrap(smp.wrapT);
      out.linear_filter = smp.magFilter != TINYGLTF_TEXTURE_FILTER_NEAREST;
      out.mipmaps = smp.minFilter == -1 || smp.minFilter >= TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_NEAREST;
    }
    s.textures.push_back(std::move(out));
    const int id = static_cast<int>(s.textures.size() - 1);
    texture_map[index] = id;
    return TextureRef{id, scale};
  }

  static Result<void> to_rgba8(const tinygltf::Image& img, Texture& out, const std::string& label) {
    const std::size_t px = static_cast<std::size_t>(img.width) * img.height;
    const int comps = img.component, bytes = img.bits == 16 ? 2 : 1;
    if (comps < 1 || comps > 4 || (img.bits != 8 && img.bits != 16) ||
        img.image.size() != px * comps * bytes)
      return gltf_error(fmt::format("{}: unsupported pixel layout ({} channels, {} bits)", label, comps, img.bits));
    out.rgba8.resize(px * 4);
    for (std::size_t i = 0; i < px; ++i)
      for (int c = 0; c < 4; ++c) {
        const int src = comps >= 3 ? c : (c < 3 ? 0 : 1);  // grey(+alpha) to RGBA
        if (src >= comps) { out.rgba8[i * 4 + c] = 255; continue; }
        const std::size_t o = (i * comps + src) * bytes;
        // 16-bit: keep the high byte (these textures are 8-bit on the GPU).
        out.rgba8[i * 4 + c] = bytes == 2 ? img.image[o + 1] : img.image[o];
      }
    return {};
  }

  Result<int> material(int index) {
    if (index < 0) {
      if (default_material < 0) {
        Material d;  // glTF defaults: white, metallic 1, roughness 1
        d.name = "glTF default";
        d.metallic = 1;
        d.roughness = 1;
        s.materials.push_back(d);
        default_material = static_cast<int>(s.materials.size() - 1);
      }
      return default_material;
    }
    if (!in_range(index, m.materials)) return gltf_error(fmt::format("material {} does not exist", index));
    return index;  // materials are converted up front, in order
  }

  Result<void> convert_material(int i) {
    const tinygltf::Material& g = m.materials[i];
    const std::string what = fmt::format("material {} '{}'", i, g.name);
    Material out;
    out.name = g.name;
    const auto& pbr = g.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4 || g.emissiveFactor.size() > 3 || (g.emissiveFactor.size() != 3 && !g.emissiveFactor.empty()))
      return gltf_error(what + ": baseColorFactor/emissiveFactor have the wrong length");
    out.base_color = {pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]};
    out.alpha = pbr.baseColorFactor[3];
    out.metallic = pbr.metallicFactor;
    out.roughness = pbr.roughnessFactor;
    double strength = 1.0;
    if (auto it = g.extensions.find("KHR_materials_emissive_strength"); it != g.extensions.end()) {
      const tinygltf::Value& v = it->second.Get("emissiveStrength");
      if (v.IsNumber()) strength = v.GetNumberAsDouble();
    }
    if (auto it = g.extensions.find("KHR_materials_ior"); it != g.extensions.end()) {
      const tinygltf::Value& v = it->second.Get("ior");
      if (v.IsNumber() && v.GetNumberAsDouble() >= 1.0) {
        const double n = v.GetNumberAsDouble(), r = (n - 1) / (n + 1);
        out.dielectric_f0 = r * r;  // RTR4 eq. 9.17
      }
    }
    if (!std::isfinite(strength) || strength < 0) return gltf_error(what + ": emissiveStrength must be finite and >= 0");
    if (g.emissiveFactor.size() == 3)
      out.emissive_nits = Vec3{g.emissiveFactor[0], g.emissiveFactor[1], g.emissiveFactor[2]} * (strength * options.gltf_emissive_nits);
    out.alpha_mode = g.alphaMode == "MASK" ? AlphaMode::mask : g.alphaMode == "BLEND" ? AlphaMode::blend : AlphaMode::opaque;
    out.alpha_cutoff = g.alphaCutoff;
    out.double_sided = g.doubleSided;
    const struct { TextureRef* dst; int index, coord; double scale; const char* name; } refs[] = {
        {&out.base_color_texture, pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, 1.0, "baseColorTexture"},
        {&out.metallic_roughness_texture, pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord, 1.0, "metallicRoughnessTexture"},
        {&out.normal_texture, g.normalTexture.index, g.normalTexture.texCoord, g.normalTexture.scale, "normalTexture"},
        {&out.occlusion_texture, g.occlusionTexture.index, g.occlusionTexture.texCoord, g.occlusionTexture.strength, "occlusionTexture"},
        {&out.emissive_texture, g.emissiveTexture.index, g.emissiveTexture.texCoord, 1.0, "emissiveTexture"}};
    for (const auto& r : refs) {
      auto t = texture(r.index, r.coord, r.scale, what + " " + r.name);
      if (!t) return t.error();
      *r.dst = *t;
    }
    // Clamp what glTF allows to be slightly out of range in practice; NaN stays NaN and fails validation.
    s.materials.push_back(std::move(out));
    return {};
  }

  // ---- Nodes ---------------------------------------------------------------------------------------
  static Result<Mat4> node_matrix(const tinygltf::Node& n) {
    if (n.matrix.size() == 16) {
      Mat4 r;
      for (int k = 0; k < 16; ++k) r.m[k] = n.matrix[k];  // glTF is column-major too
      return r;
    }
    if (!n.matrix.empty() || (!n.translation.empty() && n.translation.size() != 3) ||
        (!n.rotation.empty() && n.rotation.size() != 4) || (!n.scale.empty() && n.scale.size() != 3))
      return gltf_error(fmt::format("node '{}': matrix/translation/rotation/scale have the wrong length", n.name));
    Mat4 t, r, s;
    if (n.translation.size() == 3) t = translate({n.translation[0], n.translation[1], n.translation[2]});
    if (n.rotation.size() == 4) r = from_quaternion(n.rotation[0], n.rotation[1], n.rotation[2], n.rotation[3]);
    if (n.scale.size() == 3) s = scale({n.scale[0], n.scale[1], n.scale[2]});
    return t * r * s;
  }

  // Visits a node and its children; records each visit in `graph` (animations re-pose it).
  Result<void> visit(int index, const Mat4& parent, int depth, std::set<int>& path, int parent_record) {
    if (!in_range(index, m.nodes)) return gltf_error(fmt::format("node {} does not exist", index));
    if (depth > kMaxNodeDepth || path.count(index)) return gltf_error(fmt::format("node {} is part of a cycle or nests too deep", index));
    const tinygltf::Node& n = m.nodes[index];
    auto local = node_matrix(n);
    if (!local) return local.error();
    const Mat4 world = parent * *local;
    AnimatedNode rec = rest_pose(n);
    rec.gltf_node = index;
    rec.parent = parent_record;
    rec.first_instance = static_cast<int>(s.instances.size());
    if (n.mesh >= 0)
      if (auto r = add_mesh(n.mesh, world); !r) return r;
    rec.instance_count = static_cast<int>(s.instances.size()) - rec.first_instance;
    if (n.camera >= 0 && !s.camera) {
      if (auto r = add_camera(n.camera, world); !r) return r;
      rec.camera = true;
    }
    if (auto it = n.extensions.find("KHR_lights_punctual"); it != n.extensions.end()) {
      const tinygltf::Value& li = it->second.Get("light");
      if (!li.IsInt() || !in_range(li.GetNumberAsInt(), m.lights))
        return gltf_error(fmt::format("node {}: KHR_lights_punctual light does not exist", index));
      if (auto r = add_light(li.GetNumberAsInt(), world); !r) return r;
      rec.lights.push_back(static_cast<int>(s.lights.size()) - 1);
    }
    graph.push_back(std::move(rec));
    const int self = static_cast<int>(graph.size()) - 1;
    path.insert(index);
    for (int c : n.children)
      if (auto r = visit(c, world, depth + 1, path, self); !r) return r;
    path.erase(index);
    return {};
  }

  static AnimatedNode rest_pose(const tinygltf::Node& n) {
    AnimatedNode a;
    if (n.matrix.size() == 16) {
      Mat4 r;
      for (int k = 0; k < 16; ++k) r.m[k] = n.matrix[k];
      a.matrix = r;
      return a;
    }
    if (n.translation.size() == 3) a.translation = {n.translation[0], n.translation[1], n.translation[2]};
    if (n.rotation.size() == 4) a.rotation = {n.rotation[0], n.rotation[1], n.rotation[2], n.rotation[3]};
    if (n.scale.size() == 3) a.scale = {n.scale[0], n.scale[1], n.scale[2]};
    return a;
  }

  Result<void> add_mesh(int mesh_index, const Mat4& world) {
    if (!in_range(mesh_index, m.meshes)) return gltf_error(fmt::format("mesh {} does not exist", mesh_index));
    const tinygltf::Mesh& mesh = m.meshes[mesh_index];
    for (std::size_t p = 0; p < mesh.primitives.size(); ++p) {
      const auto key = std::make_pair(mesh_index, static_cast<int>(p));
      auto it = primitives.find(key);
      if (it == primitives.end()) {
        const tinygltf::Primitive& prim = mesh.primitives[p];
        const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN) {
          s.warnings.push_back(fmt::format("mesh {} primitive {}: points and lines are not drawn", mesh_index, p));
          continue;
        }
        auto mat = material(prim.material);
        if (!mat) return mat.error();
        const bool tangents = s.materials[*mat].normal_texture.index >= 0;
        auto converted = convert_primitive(m, prim, fmt::format("mesh {} '{}' primitive {}", mesh_index, mesh.name, p),
                                           tangents, s.warnings);
        if (!converted) return converted.error();
        s.meshes.push_back(std::move(*converted));
        it = primitives.emplace(key, std::make_pair(static_cast<int>(s.meshes.size() - 1), *mat)).first;
      }
      s.instances.push_back({it->second.first, it->second.second, world});
    }
    return {};
  }

  Result<void> add_camera(int index, const Mat4& world) {
    if (!in_range(index, m.cameras)) return gltf_error(fmt::format("camera {} does not exist", index));
    const tinygltf::Camera& c = m.cameras[index];
    Camera out;
    out.position = world.transform_point({0, 0, 0});
    out.target = world.transform_point({0, 0, -1});  // glTF cameras look down -Z
    out.up = normalize(world.transform_dir({0, 1, 0}));
    if (c.type == "perspective") {
      out.yfov_rad = c.perspective.yfov;
      out.znear_m = c.perspective.znear;
      out.zfar_m = c.perspective.zfar;
    } else {
      s.warnings.push_back(fmt::format("camera {}: orthographic cameras are drawn with a 45 degree perspective", index));
    }
    if (!(out.yfov_rad > 0 && out.yfov_rad < kPi) || !std::isfinite(out.znear_m) || !std::isfinite(out.zfar_m) ||
        out.znear_m < 0 || (out.zfar_m != 0 && out.zfar_m <= out.znear_m))
      return gltf_error(fmt::format("camera {}: yfov/znear/zfar are out of range", index));
    s.camera = out;
    return {};
  }

  Result<void> add_light(int index, const Mat4& world) {
    const tinygltf::Light& g = m.lights[index];
    Light l;
    l.name = g.name;
    if (g.color.size() == 3) l.color = {g.color[0], g.color[1], g.color[2]};
    else if (!g.color.empty()) return gltf_error(fmt::format("light {}: color must have 3 components", index));
    l.position = world.transform_point({0, 0, 0});
    l.direction = normalize(world.transform_dir({0, 0, -1}));  // KHR_lights_punctual: lights point down -Z
    l.range_m = g.range;
    // KHR_lights_punctual units: directional in lux, point and spot in candela.
    if (g.type == "directional") {
      l.type = LightType::directional;
      l.illuminance_lux = g.intensity;
    } else if (g.type == "point" || g.type == "spot") {
      l.type = g.type == "point" ? LightType::point : LightType::spot;
      l.intensity_cd = g.intensity;
      l.inner_cone_rad = g.spot.innerConeAngle;
      l.outer_cone_rad = g.spot.outerConeAngle;
    } else {
      return gltf_error(fmt::format("light {}: unknown type '{}'", index, g.type));
    }
    s.lights.push_back(l);
    return {};
  }

  // ---- Animations (glTF 2.0 §3.11) ---------------------------------------------------------
  // All of the file's animations play together from t = 0: exporters write one animation
  // per animated object or action (Blender: one per object's action), and a shot needs all
  // of them. Two channels on the same node property: the later one wins (a warning).
  Result<Track> sampler_track(const tinygltf::AnimationSampler& smp, NodePath path, const std::string& what) {
    Track t;
    if (smp.interpolation.empty() || smp.interpolation == "LINEAR") t.interpolation = Interpolation::linear;
    else if (smp.interpolation == "STEP") t.interpolation = Interpolation::step;
    else if (smp.interpolation == "CUBICSPLINE") t.interpolation = Interpolation::cubic_spline;
    else return gltf_error(fmt::format("{}: interpolation '{}' is not LINEAR, STEP or CUBICSPLINE", what, smp.interpolation));
    auto in = view_accessor(m, smp.input, what + " input");
    if (!in) return in.error();
    if (in->components != 1 || in->component_type != TINYGLTF_COMPONENT_TYPE_FLOAT || !in->data)
      return gltf_error(fmt::format("{} input (accessor {}): key times must be a SCALAR float accessor with data", what, smp.input));
    auto out = view_accessor(m, smp.output, what + " output");
    if (!out) return out.error();
    t.rotation = path == NodePath::rotation;
    t.components = t.rotation ? 4 : 3;
    if (out->components != t.components)
      return gltf_error(fmt::format("{} output (accessor {}): {} components per key, {} needs {}", what, smp.output,
                                    out->components, path == NodePath::rotation ? "rotation" : "translation/scale", t.components));
    // §3.11.2's accessor table: float everywhere; rotations also normalised (u)byte/(u)short.
    const int ct = out->component_type;
    const bool normalized_int = out->normalized && (ct == TINYGLTF_COMPONENT_TYPE_BYTE || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                                    ct == TINYGLTF_COMPONENT_TYPE_SHORT || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
    if (ct != TINYGLTF_COMPONENT_TYPE_FLOAT && !(t.rotation && normalized_int))
      return gltf_error(fmt::format("{} output (accessor {}): component type {} is not allowed for {} (float{})", what,
                                    smp.output, ct, t.rotation ? "rotation" : "translation/scale",
                                    t.rotation ? " or normalized byte/short" : ""));
    const std::size_t per_key = t.interpolation == Interpolation::cubic_spline ? 3 : 1;
    if (out->count != in->count * per_key)
      return gltf_error(fmt::format("{}: {} output elements for {} key times (expected {}{})", what, out->count, in->count,
                                    in->count * per_key, per_key == 3 ? ": in-tangent, value, out-tangent per key" : ""));
    animation_values += out->count * static_cast<std::size_t>(t.components);
    if (animation_values > kMaxAnimationValues)
      return gltf_error(fmt::format("{}: the animations hold more than {} values", what, kMaxAnimationValues));
    t.times_s.resize(in->count);
    for (std::size_t i = 0; i < in->count; ++i) t.times_s[i] = read_component(*in, i, 0);
    t.values.resize(out->count * static_cast<std::size_t>(t.components));
    for (std::size_t i = 0; i < out->count; ++i)
      for (int c = 0; c < t.components; ++c) t.values[i * static_cast<std::size_t>(t.components) + static_cast<std::size_t>(c)] = read_component(*out, i, c);
    if (auto v = validate_track(t, what, "gltf.invalid"); !v) return v.error();
    return t;
  }

  Result<void> convert_animations() {
    if (m.animations.empty()) return {};
    std::vector<std::vector<int>> records(m.nodes.size());
    for (std::size_t i = 0; i < graph.size(); ++i) records[static_cast<std::size_t>(graph[i].gltf_node)].push_back(static_cast<int>(i));
    auto anim = std::make_shared<SceneAnimation>();
    std::map<std::pair<int, NodePath>, std::string> targeted;
    for (std::size_t a = 0; a < m.animations.size(); ++a) {
      const tinygltf::Animation& an = m.animations[a];
      bool warned_weights = false;
      for (std::size_t c = 0; c < an.channels.size(); ++c) {
        const tinygltf::AnimationChannel& ch = an.channels[c];
        const std::string what = fmt::format("animations[{}] '{}' channels[{}]", a, an.name, c);
        if (ch.target_path == "weights") {
          if (!warned_weights) s.warnings.push_back(fmt::format("animations[{}] '{}': morph target weights are not animated", a, an.name));
          warned_weights = true;
          continue;
        }
        const std::optional<NodePath> path = ch.target_path == "translation" ? std::optional(NodePath::translation)
                                             : ch.target_path == "rotation"  ? std::optional(NodePath::rotation)
                                             : ch.target_path == "scale"     ? std::optional(NodePath::scale)
                                                                             : std::nullopt;
        if (!path) return gltf_error(fmt::format("{}: target.path '{}' is not translation, rotation, scale or weights", what, ch.target_path));
        if (ch.target_node < 0) {  // §3.11.1: no node (an extension's target): ignored
          s.warnings.push_back(what + ": has no target node; ignored");
          continue;
        }
        if (!in_range(ch.target_node, m.nodes)) return gltf_error(fmt::format("{}: target node {} does not exist", what, ch.target_node));
        if (m.nodes[static_cast<std::size_t>(ch.target_node)].matrix.size() == 16)
          return gltf_error(fmt::format("{}: target node {} has a matrix (§3.11: only TRS nodes may be animated)", what, ch.target_node));
        if (!in_range(ch.sampler, an.samplers)) return gltf_error(fmt::format("{}: sampler {} does not exist", what, ch.sampler));
        auto track = sampler_track(an.samplers[static_cast<std::size_t>(ch.sampler)], *path,
                                   fmt::format("{} sampler {}", what, ch.sampler));
        if (!track) return track.error();
        const auto [it, fresh] = targeted.emplace(std::make_pair(ch.target_node, *path), what);
        if (!fresh) s.warnings.push_back(fmt::format("{} and {} animate node {} {}: the later one plays", it->second, what,
                                                     ch.target_node, ch.target_path));
        for (int rec : records[static_cast<std::size_t>(ch.target_node)]) anim->channels.push_back({rec, *path, *track});
      }
    }
    if (anim->channels.empty()) return {};
    anim->nodes = std::move(graph);
    s.animation = std::move(anim);
    return {};
  }

  Result<void> run() {
    for (std::size_t i = 0; i < m.materials.size(); ++i)
      if (auto r = convert_material(static_cast<int>(i)); !r) return r;
    std::vector<int> roots;
    if (in_range(m.defaultScene, m.scenes)) roots = m.scenes[m.defaultScene].nodes;
    else if (!m.scenes.empty()) roots = m.scenes[0].nodes;
    else {
      std::vector<bool> child(m.nodes.size(), false);
      for (const auto& n : m.nodes)
        for (int c : n.children) if (in_range(c, m.nodes)) child[c] = true;
      for (std::size_t i = 0; i < m.nodes.size(); ++i) if (!child[i]) roots.push_back(static_cast<int>(i));
    }
    std::set<int> path;
    for (int r : roots)
      if (auto e = visit(r, Mat4{}, 0, path, -1); !e) return e;
    if (s.instances.empty()) return gltf_error("the scene has no triangle meshes");
    return convert_animations();
  }
};

Result<tinygltf::Model> parse(std::span<const std::uint8_t> bytes, const std::filesystem::path& base_dir,
                              const SceneLoadOptions& options, std::vector<std::string>& warnings) {
  if (bytes.size() > kMaxFileBytes) return gltf_error("glTF file is larger than 1 GiB");
  if (bytes.empty()) return gltf_error("glTF file is empty");
  if (auto ok = check_json_and_buffer_views(bytes); !ok) return ok.error();
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&guarded_image_loader, nullptr);
  std::error_code ec;
  Confinement root{base_dir.empty() ? std::filesystem::path() : std::filesystem::weakly_canonical(base_dir, ec), &options.files};
  if (ec) root.dir.clear();
  if (!options.allow_files) loader.SetFsCallbacks({&confined_exists, &no_expand, &confined_read, &no_write, &root});
  else loader.SetFsCallbacks({&plain_exists, &tinygltf::ExpandFilePath, &plain_read, &no_write, &root});
  tinygltf::Model model;
  std::string err, warn;
  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  const auto len = static_cast<unsigned int>(bytes.size());
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), len, base_dir.string())
                         : loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                                      len, base_dir.string());
  if (!warn.empty()) warnings.push_back("tinygltf: " + warn.substr(0, warn.find_last_not_of('\n') + 1));
  if (!ok) {
    while (!err.empty() && err.back() == '\n') err.pop_back();
    for (auto& c : err) if (c == '\n') c = ';';
    return gltf_error("glTF could not be read: " + (err.empty() ? std::string("unknown error") : err));
  }
  return model;
}

Result<Scene> convert(std::span<const std::uint8_t> bytes, const std::filesystem::path& base_dir,
                      const SceneLoadOptions& options) {
  std::vector<std::string> warnings;
  auto model = parse(bytes, base_dir, options, warnings);
  if (!model) return model.error();
  Loader l{*model, options, {}, {}, {}, -1, {}, 0};
  if (auto r = l.run(); !r) return r.error();
  for (auto& w : warnings) l.s.warnings.push_back(std::move(w));
  return std::move(l.s);
}

// glTF files bring exactly their own lights and camera; a file without any gets a
// default rig, and the warnings say so.
void add_default_rig(Scene& s, bool rig) {
  if (s.lights.empty() && rig) {
    Light key;
    key.name = "default key light";
    key.direction = normalize(Vec3{0.35, -0.55, -0.75});
    key.illuminance_lux = 100;
    s.lights.push_back(key);
    s.ambient_nits = Vec3{10, 10, 10};
    s.warnings.push_back("glTF file has no lights: added a default rig (100 lux key light, 10 cd/m2 ambient)");
  }
  if (!s.camera) s.warnings.push_back("glTF file has no camera: using a default camera that frames the scene");
}

Result<std::vector<std::uint8_t>> read_file(const std::filesystem::path& path, const io::InputFiles& files) {
  auto bytes = files.read(path, kMaxFileBytes);
  if (!bytes && bytes.error().code == "file.too_large")
    return make_error("gltf.file", fmt::format("'{}' is larger than 1 GiB", path.string()));
  if (!bytes) return io::reader_error(bytes.error(), "gltf.file", "gltf.file");
  return std::vector<std::uint8_t>(bytes->begin(), bytes->end());
}

}  // namespace

Result<Scene> load_gltf_raw(const std::filesystem::path& path, const SceneLoadOptions& options) {
  auto bytes = read_file(path, options.files);
  if (!bytes) return bytes.error();
  auto s = convert(*bytes, path.parent_path(), options);
  if (!s) return make_error(s.error().code, fmt::format("{}: {}", path.filename().string(), s.error().message));
  s->name = path.stem().string();
  return s;
}

Result<Scene> load_gltf_file(const std::filesystem::path& path, const SceneLoadOptions& options) {
  auto s = load_gltf_raw(path, options);
  if (!s) return s;
  add_default_rig(*s, options.default_rig);
  if (auto v = validate(*s, options.limits); !v) return v.error();
  return s;
}

Result<Scene> load_gltf_memory(std::span<const std::uint8_t> bytes, const std::filesystem::path& base_dir,
                               const SceneLoadOptions& options) {
  auto s = convert(bytes, base_dir, options);
  if (!s) return s;
  s->name = "gltf";
  add_default_rig(*s, options.default_rig);
  if (auto v = validate(*s, options.limits); !v) return v.error();
  return s;
}

}  // namespace hdrd::shading

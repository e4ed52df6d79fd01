// Scene upload: vertex/index buffers, material textures (sRGB where glTF says so),
// and the uniform blocks of gpu_blocks.hpp.
#include <algorithm>
#include <array>
#include <cstring>

#include <fmt/format.h>

#include "encode/colour/transfer.hpp"
#include "shading/materials.hpp"
#include "shading/renderer_impl.hpp"

namespace hdrd::shading {
namespace {

gpu::mat4 to_gpu(const Mat4& m) {
  gpu::mat4 r{};
  for (int i = 0; i < 16; ++i) r[i] = static_cast<float>(m.m[i]);
  return r;
}
gpu::vec4 to_gpu(Vec3 v, double w) { return {float(v.x), float(v.y), float(v.z), float(w)}; }

GLint gl_wrap(Wrap w) {
  switch (w) {
    case Wrap::clamp: return GL_CLAMP_TO_EDGE;
    case Wrap::mirror: return GL_MIRRORED_REPEAT;
    case Wrap::repeat: break;
  }
  return GL_REPEAT;
}

int mip_levels(int w, int h) {
  int levels = 1;
  while ((std::max(w, h) >> levels) > 0) ++levels;
  return levels;
}


// sRGB-encoded texels, decoded on the CPU with the IEC 61966-2-1 curve (encode/transfer)
// into correctly rounded halves: llvmpipe's GL_SRGB8_ALPHA8 sampler approximates the
// curve (136/255 -> 0.24686 instead of 0.24620), halves stay within 6e-5.
std::vector<std::uint16_t> decode_srgb_to_half(const Texture& t) {
  std::array<std::uint16_t, 256> colour{}, alpha{};
  for (int i = 0; i < 256; ++i) {
    colour[i] = float_to_half(static_cast<float>(transfer::srgb_eotf(i / 255.0)));
    alpha[i] = float_to_half(static_cast<float>(i / 255.0));
  }
  std::vector<std::uint16_t> out(t.rgba8.size());
  for (std::size_t i = 0; i < t.rgba8.size(); ++i) out[i] = (i % 4 == 3 ? alpha : colour)[t.rgba8[i]];
  return out;
}

GlName upload_texture(const GlApi& gl, const Texture& t, bool srgb) {
  GlName tex = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, tex.id());
  const int levels = t.mipmaps ? mip_levels(t.width, t.height) : 1;
  gl.TexStorage2D(GL_TEXTURE_2D, levels, srgb ? GL_RGBA16F : GL_RGBA8, t.width, t.height);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (srgb) {
    const auto halves = decode_srgb_to_half(t);
    gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, t.width, t.height, GL_RGBA, GL_HALF_FLOAT, halves.data());
  } else {
    gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, t.width, t.height, GL_RGBA, GL_UNSIGNED_BYTE, t.rgba8.data());
  }
  if (levels > 1) gl.GenerateMipmap(GL_TEXTURE_2D);
  const GLint mag = t.linear_filter ? GL_LINEAR : GL_NEAREST;
  const GLint min = levels > 1 ? (t.linear_filter ? GL_LINEAR_MIPMAP_LINEAR : GL_NEAREST_MIPMAP_NEAREST) : mag;
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, min);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, mag);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, gl_wrap(t.wrap_s));
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, gl_wrap(t.wrap_t));
  return tex;
}

GpuMesh upload_mesh(const GlApi& gl, const Mesh& m) {
  GpuMesh g;
  g.vao = gen_vertex_array(gl);
  g.vbo = gen_buffer(gl);
  g.ibo = gen_buffer(gl);
  gl.BindVertexArray(g.vao.id());
  gl.BindBuffer(GL_ARRAY_BUFFER, g.vbo.id());
  gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertices.size() * sizeof(Vertex)), m.vertices.data(),
                GL_STATIC_DRAW);
  gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ibo.id());
  gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.indices.size() * sizeof(std::uint32_t)),
                m.indices.data(), GL_STATIC_DRAW);
  const GLsizei stride = sizeof(Vertex);
  const struct { GLuint loc; GLint size; std::size_t offset; } attribs[] = {
      {0, 3, offsetof(Vertex, position)}, {1, 3, offsetof(Vertex, normal)},
      {2, 4, offsetof(Vertex, tangent)}, {3, 2, offsetof(Vertex, uv)}};
  for (const auto& a : attribs) {
    gl.EnableVertexAttribArray(a.loc);
    gl.VertexAttribPointer(a.loc, a.size, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(a.offset));
  }
  gl.BindVertexArray(0);
  g.index_count = static_cast<GLsizei>(m.indices.size());
  return g;
}

gpu::DrawBlock draw_block(const Scene& scene, const Instance& inst) {
  const Material& m = scene.materials[inst.material];
  gpu::DrawBlock d{};
  d.model = to_gpu(inst.transform);
  d.normal_matrix = to_gpu(normal_matrix(inst.transform));
  d.base_color = to_gpu(m.base_color, m.alpha);
  d.emissive_nits = to_gpu(m.emissive_nits, 0);
  d.surface = {float(m.metallic), float(m.roughness), float(dielectric_f0_in_medium(m.dielectric_f0, scene.medium_ior)),
               float(m.f90)};
  d.extra = {float(m.fresnel_exponent), float(m.normal_texture.scale), float(m.occlusion_texture.scale),
             float(m.ambient_visibility)};
  d.metal_n = to_gpu(m.metal_n, m.alpha_cutoff);
  int bits = 0;
  if (m.base_color_texture) bits |= gpu::kTexBaseColor;
  if (m.metallic_roughness_texture) bits |= gpu::kTexMetalRough;
  if (m.normal_texture) bits |= gpu::kTexNormal;
  if (m.emissive_texture) bits |= gpu::kTexEmissive;
  if (m.occlusion_texture) bits |= gpu::kTexOcclusion;
  const int alpha_mode = m.alpha_mode == AlphaMode::mask ? 1 : m.alpha_mode == AlphaMode::blend ? 2 : 0;
  d.flags = {bits, alpha_mode, m.double_sided ? 1 : 0, determinant(inst.transform) < 0 ? -1 : 1};
  return d;
}

GlName make_ubo(const GlApi& gl, const void* data, std::size_t size) {
  GlName b = gen_buffer(gl);
  gl.BindBuffer(GL_UNIFORM_BUFFER, b.id());
  gl.BufferData(GL_UNIFORM_BUFFER, static_cast<GLsizeiptr>(size), data, GL_STATIC_DRAW);
  return b;
}

}  // namespace

Result<void> upload_geometry(Renderer::Impl& r, const Scene& scene, GpuScene& g) {
  const GlApi& gl = *r.gl;
  g.meshes.clear();
  g.textures.clear();
  for (const Mesh& m : scene.meshes) g.meshes.push_back(upload_mesh(gl, m));
  for (const Material& m : scene.materials) {
    const std::pair<const TextureRef*, bool> uses[] = {{&m.base_color_texture, true}, {&m.emissive_texture, true},
                                                       {&m.metallic_roughness_texture, false},
                                                       {&m.normal_texture, false}, {&m.occlusion_texture, false}};
    for (const auto& [ref, srgb] : uses) {
      if (!*ref) continue;
      const int key = ref->index * 2 + (srgb ? 1 : 0);
      if (!g.textures.count(key)) g.textures.emplace(key, upload_texture(gl, scene.textures[ref->index], srgb));
    }
  }
  return check_gl(gl, "uploading the scene's meshes and textures");
}

Result<void> upload_blocks(Renderer::Impl& r, const Scene& scene, const gpu::FrameBlock& frame,
                           const gpu::LightBlock& lights, GpuScene& g) {
  const GlApi& gl = *r.gl;
  g.frame_ubo = make_ubo(gl, &frame, sizeof(frame));
  g.light_ubo = make_ubo(gl, &lights, sizeof(lights));
  const auto align = static_cast<std::size_t>(std::max(r.ubo_alignment, 16));
  g.draw_stride = (sizeof(gpu::DrawBlock) + align - 1) / align * align;
  std::vector<std::uint8_t> draws(std::max<std::size_t>(1, scene.instances.size()) * g.draw_stride, 0);
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    const gpu::DrawBlock d = draw_block(scene, scene.instances[i]);
    std::memcpy(draws.data() + i * g.draw_stride, &d, sizeof(d));
  }
  g.draw_ubo = make_ubo(gl, draws.data(), draws.size());
  gl.BindBufferBase(GL_UNIFORM_BUFFER, 0, g.frame_ubo.id());
  gl.BindBufferBase(GL_UNIFORM_BUFFER, 1, g.light_ubo.id());
  return check_gl(gl, "uploading uniform blocks");
}

void draw_instance(Renderer::Impl& r, const GpuScene& g, const Scene& scene, std::size_t i, bool depth_only) {
  const GlApi& gl = *r.gl;
  const Instance& inst = scene.instances[i];
  const Material& m = scene.materials[inst.material];
  gl.BindBufferRange(GL_UNIFORM_BUFFER, 2, g.draw_ubo.id(), static_cast<GLintptr>(i * g.draw_stride),
                     sizeof(gpu::DrawBlock));
  if (!depth_only) {
    const std::pair<const TextureRef*, std::pair<int, bool>> units[] = {
        {&m.base_color_texture, {gpu::kUnitBaseColor, true}}, {&m.metallic_roughness_texture, {gpu::kUnitMetalRough, false}},
        {&m.normal_texture, {gpu::kUnitNormal, false}}, {&m.emissive_texture, {gpu::kUnitEmissive, true}},
        {&m.occlusion_texture, {gpu::kUnitOcclusion, false}}};
    for (const auto& [ref, unit] : units) {
      gl.ActiveTexture(GL_TEXTURE0 + unit.first);
      GLuint id = r.white_texture.id();
      if (*ref) id = g.textures.at(ref->index * 2 + (unit.second ? 1 : 0)).id();
      gl.BindTexture(GL_TEXTURE_2D, id);
    }
  }
  if (m.double_sided) {
    gl.Disable(GL_CULL_FACE);
  } else {
    gl.Enable(GL_CULL_FACE);
    gl.CullFace(GL_BACK);
  }
  gl.FrontFace(determinant(inst.transform) < 0 ? GL_CW : GL_CCW);  // mirrored instances flip winding
  const GpuMesh& mesh = g.meshes[inst.mesh];
  gl.BindVertexArray(mesh.vao.id());
  gl.DrawElements(GL_TRIANGLES, mesh.index_count, GL_UNSIGNED_INT, nullptr);
}

std::vector<int> supported_sample_counts(const GlApi& gl, GLenum internal_format) {
  GLint n = 0;
  gl.GetInternalformativ(GL_TEXTURE_2D_MULTISAMPLE, internal_format, GL_NUM_SAMPLE_COUNTS, 1, &n);
  std::vector<int> counts;
  if (n > 0) {
    std::vector<GLint> v(static_cast<std::size_t>(n));
    gl.GetInternalformativ(GL_TEXTURE_2D_MULTISAMPLE, internal_format, GL_SAMPLES, n, v.data());
    counts.assign(v.begin(), v.end());
  }
  gl.GetError();  // a driver without the query leaves an error; we then offer no MSAA
  std::sort(counts.begin(), counts.end());
  return counts;
}

}  // namespace hdrd::shading

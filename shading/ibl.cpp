// Environment light on the GPU: the equirectangular map as the background texture, a
// cube map resampled from it, the GGX-prefiltered mip chain of that cube (specular) and
// the CPU-integrated irradiance cube (diffuse). Built once per environment and kept.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "shading/renderer_impl.hpp"
#include "shading/shaders.hpp"

namespace hdrd::shading {
namespace {

// Largest background texture we upload (RGBA32F: 512 MiB at 8192x4096 with mips); bigger
// maps are box-filtered down first.
constexpr int kMaxBackgroundWidth = 8192;
// Cube face size of the mirror level: a quarter of the map's width, within these bounds.
constexpr int kMinCubeFace = 32, kMaxCubeFace = 512;
// The roughest level is 8x8 texels a face: GGX at roughness 1 is broad enough for it.
constexpr int kSmallestSpecularFace = 8;
// GGX samples a texel: with filtered importance sampling 128 keep the sampling pattern
// below 0.5 % on the test maps (tests/shading/environment_render_test.cpp).
constexpr int kPrefilterSamples = 128;

using Clock = std::chrono::steady_clock;

int floor_pow2(int x) {
  int p = 1;
  while (p * 2 <= x) p *= 2;
  return p;
}

int mip_count(int size) {
  int n = 1;
  while ((size >> n) > 0) ++n;
  return n;
}

// The map halved (2x2 box) until it fits `max_width`; odd edges repeat the last texel.
EnvironmentMap shrink(EnvironmentMap m, int max_width) {
  while (m.width > max_width) {
    EnvironmentMap h;
    h.width = std::max(1, m.width / 2);
    h.height = std::max(1, m.height / 2);
    h.rgb.resize(static_cast<std::size_t>(h.width) * h.height * 3);
    for (int y = 0; y < h.height; ++y)
      for (int x = 0; x < h.width; ++x) {
        Vec3 sum{0, 0, 0};
        for (int k = 0; k < 4; ++k)
          sum = sum + m.texel(std::min(2 * x + k % 2, m.width - 1), std::min(2 * y + k / 2, m.height - 1));
        float* p = h.rgb.data() + (static_cast<std::size_t>(y) * h.width + x) * 3;
        p[0] = float(sum.x / 4);
        p[1] = float(sum.y / 4);
        p[2] = float(sum.z / 4);
      }
    m = std::move(h);
  }
  return m;
}

std::vector<float> to_rgba(const std::vector<float>& rgb) {
  std::vector<float> out(rgb.size() / 3 * 4, 1.0f);
  for (std::size_t i = 0, n = rgb.size() / 3; i < n; ++i) std::copy_n(rgb.data() + i * 3, 3, out.data() + i * 4);
  return out;
}

GlName upload_background(const GlApi& gl, const EnvironmentMap& m) {
  GlName tex = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, tex.id());
  gl.TexStorage2D(GL_TEXTURE_2D, mip_count(std::max(m.width, m.height)), GL_RGBA32F, m.width, m.height);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const auto rgba = to_rgba(m.rgb);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, m.width, m.height, GL_RGBA, GL_FLOAT, rgba.data());
  gl.GenerateMipmap(GL_TEXTURE_2D);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);         // around in azimuth
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);  // at the poles
  return tex;
}

GlName make_cube(const GlApi& gl, int size, int levels) {
  GlName tex = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, tex.id());
  gl.TexStorage2D(GL_TEXTURE_CUBE_MAP, levels, GL_RGBA32F, size, size);
  set_sampling(gl, GL_TEXTURE_CUBE_MAP, levels > 1 ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE);
  return tex;
}

GlName upload_irradiance(const GlApi& gl, const IrradianceCube& c) {
  GlName tex = make_cube(gl, c.size, 1);
  std::vector<float> rgba(static_cast<std::size_t>(c.size) * c.size * 4, 1.0f);
  for (int f = 0; f < 6; ++f) {
    for (std::size_t i = 0; i < c.faces[f].size(); ++i) {
      rgba[i * 4] = float(c.faces[f][i].x);
      rgba[i * 4 + 1] = float(c.faces[f][i].y);
      rgba[i * 4 + 2] = float(c.faces[f][i].z);
    }
    gl.TexSubImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, 0, 0, 0, c.size, c.size, GL_RGBA, GL_FLOAT, rgba.data());
  }
  return tex;
}

void set_face(const GlApi& gl, GLuint program, int face) {
  const CubeFace& f = cube_faces()[static_cast<std::size_t>(face)];
  const auto set = [&](const char* name, Vec3 v) {
    gl.Uniform3f(gl.GetUniformLocation(program, name), float(v.x), float(v.y), float(v.z));
  };
  set("u_major", f.major);
  set("u_s_axis", f.s_axis);
  set("u_t_axis", f.t_axis);
}

// Draws `program` into every face of level `level` of `cube`.
Result<void> draw_faces(Renderer::Impl& r, GLuint fbo, GLuint program, GLuint cube, int level, int size) {
  const GlApi& gl = *r.gl;
  gl.BindFramebuffer(GL_FRAMEBUFFER, fbo);
  gl.Viewport(0, 0, size, size);
  for (int f = 0; f < 6; ++f) {
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, cube, level);
    if (f == 0)
      if (auto e = check_framebuffer(gl, "environment cube face"); !e) return e;
    set_face(gl, program, f);
    gl.DrawArrays(GL_TRIANGLES, 0, 3);
  }
  return {};
}

// The equirectangular map resampled into a cube with a full box-filtered mip chain.
Result<GlName> base_cube(Renderer::Impl& r, GLuint fbo, const GlName& background, int background_width, int face) {
  const GlApi& gl = *r.gl;
  GlName cube = make_cube(gl, face, mip_count(face));
  gl.UseProgram(r.cube_program.id());
  // The source level whose texels (360 deg / width at the equator) match a face texel's 90 deg / face.
  const double lod = std::max(0.0, std::log2(background_width / (4.0 * face)));
  gl.Uniform1f(gl.GetUniformLocation(r.cube_program.id(), "u_lod"), float(lod));
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D, background.id());
  if (auto e = draw_faces(r, fbo, r.cube_program.id(), cube.id(), 0, face); !e) return e.error();
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, cube.id());
  gl.GenerateMipmap(GL_TEXTURE_CUBE_MAP);
  return cube;
}

Result<void> prefilter(Renderer::Impl& r, GLuint fbo, const GlName& source, int face, GpuEnvironment& env) {
  const GlApi& gl = *r.gl;
  const GLuint p = r.prefilter_program.id();
  env.specular_levels = std::max(1, mip_count(face) - mip_count(kSmallestSpecularFace) + 1);
  env.specular = make_cube(gl, face, env.specular_levels);
  gl.UseProgram(p);
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, source.id());
  gl.Uniform1i(gl.GetUniformLocation(p, "u_samples"), kPrefilterSamples);
  gl.Uniform1f(gl.GetUniformLocation(p, "u_texel_sr"), float(4 * kPi / (6.0 * face * face)));
  gl.Uniform1f(gl.GetUniformLocation(p, "u_max_lod"), float(mip_count(face) - 1));
  for (int level = 0; level < env.specular_levels; ++level) {
    // Level m holds perceptual roughness m / (levels - 1); the lit shader samples LOD = roughness * (levels - 1).
    const double roughness = env.specular_levels > 1 ? double(level) / (env.specular_levels - 1) : 0.0;
    gl.Uniform1f(gl.GetUniformLocation(p, "u_alpha"), float(roughness * roughness));
    if (auto e = draw_faces(r, fbo, p, env.specular.id(), level, std::max(1, face >> level)); !e) return e;
  }
  return {};
}

Result<void> upload(Renderer::Impl& r, GpuEnvironment& env) {
  const GlApi& gl = *r.gl;
  GLint max_size = 0;
  gl.GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  const EnvironmentMap map = shrink(std::move(env.lighting.map), std::min(kMaxBackgroundWidth, std::max(max_size, 64)));
  env.lighting.map = {};
  env.background = upload_background(gl, map);
  env.background_width = map.width;
  env.irradiance = upload_irradiance(gl, env.lighting.irradiance);
  if (!gl.gles) gl.Enable(GL_TEXTURE_CUBE_MAP_SEAMLESS);  // always on in GLES 3
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_BLEND);
  gl.BindVertexArray(r.empty_vao.id());
  const int face = std::clamp(floor_pow2(map.width / 4), kMinCubeFace, kMaxCubeFace);
  GlName fbo = gen_framebuffer(gl);
  auto cube = base_cube(r, fbo.id(), env.background, env.background_width, face);
  if (!cube) return cube.error();
  if (auto e = prefilter(r, fbo.id(), *cube, face, env); !e) return e;
  gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  return check_gl(gl, "prefiltering the environment");
}

}  // namespace

Result<void> init_ibl(Renderer::Impl& r) {
  const GlApi& gl = *r.gl;
  auto bg = build_program(gl, "background", shaders::background_vertex(gl), shaders::background_fragment(gl));
  if (!bg) return bg.error();
  r.background_program = std::move(*bg);
  auto cube = build_program(gl, "equirect-to-cube", shaders::fullscreen_vertex(gl), shaders::equirect_to_cube_fragment(gl));
  if (!cube) return cube.error();
  r.cube_program = std::move(*cube);
  auto pre = build_program(gl, "prefilter", shaders::fullscreen_vertex(gl), shaders::prefilter_ggx_fragment(gl));
  if (!pre) return pre.error();
  r.prefilter_program = std::move(*pre);
  return {};
}

Result<const GpuEnvironment*> prepare_environment(Renderer::Impl& r, const EnvironmentSpec& spec, double& spent_ms) {
  const std::string key = environment_cache_key(spec);
  if (r.environment && r.environment->key == key) return &*r.environment;
  const auto t0 = Clock::now();
  r.environment.reset();  // free the old textures before building new ones
  auto lighting = build_environment(spec);
  if (!lighting) return lighting.error();
  GpuEnvironment env;
  env.key = key;
  env.lighting = std::move(*lighting);
  if (auto e = upload(r, env); !e) return e.error();
  r.gl->Finish();
  spent_ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  r.environment = std::move(env);
  return &*r.environment;
}

void bind_environment(Renderer::Impl& r, const GpuEnvironment* env) {
  const GlApi& gl = *r.gl;
  gl.ActiveTexture(GL_TEXTURE0 + gpu::kUnitEnvSpecular);
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, env ? env->specular.id() : 0);
  gl.ActiveTexture(GL_TEXTURE0 + gpu::kUnitEnvIrradiance);
  gl.BindTexture(GL_TEXTURE_CUBE_MAP, env ? env->irradiance.id() : 0);
  gl.ActiveTexture(GL_TEXTURE0 + gpu::kUnitEnvBackground);
  gl.BindTexture(GL_TEXTURE_2D, env ? env->background.id() : 0);
  if (env && !gl.gles) gl.Enable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
}

void background_pass(Renderer::Impl& r) {
  const GlApi& gl = *r.gl;
  gl.UseProgram(r.background_program.id());
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LEQUAL);
  gl.DepthMask(GL_FALSE);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_BLEND);
  gl.BindVertexArray(r.empty_vao.id());
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.DepthMask(GL_TRUE);
  gl.DepthFunc(GL_LESS);
}

}  // namespace hdrd::shading

// One frame: camera and light set-up, shadow pass, lit pass (MSAA), tone-map-aware
// resolve, float readback.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "shading/animation.hpp"
#include "shading/renderer_impl.hpp"
#include "shading/shaders.hpp"
#include "shading/shadows.hpp"

namespace hdrd::shading {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

gpu::mat4 to_gpu(const Mat4& m) {
  gpu::mat4 r{};
  for (int i = 0; i < 16; ++i) r[i] = static_cast<float>(m.m[i]);
  return r;
}
gpu::vec4 to_gpu(Vec3 v, double w) { return {float(v.x), float(v.y), float(v.z), float(w)}; }

constexpr float kHalfMax = 65504.0f;

Camera resolve_camera(const Scene& s, const RenderSettings& settings) {
  const double aspect = double(settings.width) / settings.height;
  Camera c = s.camera ? *s.camera : default_camera(s, aspect);
  if (settings.camera) {
    if (settings.camera->position) c.position = *settings.camera->position;
    if (settings.camera->target) c.target = *settings.camera->target;
    if (settings.camera->yfov_deg) c.yfov_rad = *settings.camera->yfov_deg * kPi / 180.0;
  }
  return c;
}

// Near/far planes around the scene bounds unless the camera fixes them.
std::pair<double, double> depth_range(const Camera& c, const Bounds& b) {
  if (c.znear_m > 0 && c.zfar_m > c.znear_m) return {c.znear_m, c.zfar_m};
  const double dist = length(b.center() - c.position), radius = std::max(b.radius(), 1e-3);
  const double zfar = c.zfar_m > 0 ? c.zfar_m : (dist + radius) * 1.01 + 1e-3;
  const double znear = c.znear_m > 0 ? c.znear_m : std::max(zfar * 1e-4, (dist - radius) * 0.99);
  return {znear, zfar};
}

// The brightest directional light that casts shadows, or -1.
int shadow_light(const Scene& s) {
  int best = -1;
  double best_e = 0;
  for (std::size_t i = 0; i < s.lights.size(); ++i) {
    const Light& l = s.lights[i];
    const double e = l.illuminance_lux * luminance(l.color);
    if (l.type == LightType::directional && l.cast_shadows && e > best_e) {
      best = static_cast<int>(i);
      best_e = e;
    }
  }
  return best;
}

gpu::LightBlock light_block(const Scene& s, int shadow_index) {
  gpu::LightBlock block{};
  for (std::size_t i = 0; i < s.lights.size(); ++i) {
    const Light& l = s.lights[i];
    gpu::LightEntry& e = block.lights[i];
    const double amount = l.type == LightType::directional ? l.illuminance_lux : l.intensity_cd;
    const int type = l.type == LightType::directional ? 0 : l.type == LightType::point ? 1 : 2;
    e.color_intensity = to_gpu(l.color * amount, 0);
    e.position_type = to_gpu(l.position, type);
    e.direction_range = to_gpu(normalize(l.direction), l.range_m);
    // glTF KHR_lights_punctual's smooth cone falloff as scale/offset on cos(angle).
    const double cos_outer = std::cos(l.outer_cone_rad), cos_inner = std::cos(l.inner_cone_rad);
    const double scale = 1.0 / std::max(1e-3, cos_inner - cos_outer);
    e.spot = {float(scale), float(-cos_outer * scale), static_cast<int>(i) == shadow_index ? 1.0f : 0.0f, 0};
  }
  return block;
}

Result<void> ensure_targets(Renderer::Impl& r, const RenderSettings& s, int samples) {
  Targets& t = r.targets;
  if (t.width == s.width && t.height == s.height && t.samples == samples && t.format == s.target && t.fbo) return {};
  const GlApi& gl = *r.gl;
  t = Targets{};
  r.has_frame = false;
  const GLenum color_format = s.target == TargetFormat::rgba16f ? GL_RGBA16F : GL_RGBA32F;
  t.color = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, t.color.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, color_format, s.width, s.height);
  set_sampling(gl, GL_TEXTURE_2D, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  t.depth = gen_renderbuffer(gl);
  gl.BindRenderbuffer(GL_RENDERBUFFER, t.depth.id());
  gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, 0, GL_DEPTH_COMPONENT32F, s.width, s.height);
  t.fbo = gen_framebuffer(gl);
  gl.BindFramebuffer(GL_FRAMEBUFFER, t.fbo.id());
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t.color.id(), 0);
  gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t.depth.id());
  if (auto e = check_gl(gl, fmt::format("allocating a {}x{} render target", s.width, s.height)); !e) return e;
  if (auto e = check_framebuffer(gl, "render target"); !e) return e;
  if (samples > 1) {
    t.msaa_color = gen_texture(gl);
    gl.BindTexture(GL_TEXTURE_2D_MULTISAMPLE, t.msaa_color.id());
    gl.TexStorage2DMultisample(GL_TEXTURE_2D_MULTISAMPLE, samples, color_format, s.width, s.height, GL_TRUE);
    t.msaa_depth = gen_renderbuffer(gl);
    gl.BindRenderbuffer(GL_RENDERBUFFER, t.msaa_depth.id());
    gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT32F, s.width, s.height);
    t.msaa_fbo = gen_framebuffer(gl);
    gl.BindFramebuffer(GL_FRAMEBUFFER, t.msaa_fbo.id());
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D_MULTISAMPLE, t.msaa_color.id(), 0);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t.msaa_depth.id());
    if (auto e = check_gl(gl, fmt::format("allocating a {}x{} {}x MSAA target", s.width, s.height, samples)); !e)
      return e;
    if (auto e = check_framebuffer(gl, "MSAA render target"); !e) return e;
  }
  t.width = s.width;
  t.height = s.height;
  t.samples = samples;
  t.format = s.target;
  return {};
}

Result<void> ensure_shadow_map(Renderer::Impl& r, int size) {
  if (r.shadow_size == size && r.shadow_fbo) return {};
  const GlApi& gl = *r.gl;
  r.shadow_map = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, r.shadow_map.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, size, size);
  set_sampling(gl, GL_TEXTURE_2D, GL_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE);  // 2x2 PCF in hardware
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  r.shadow_fbo = gen_framebuffer(gl);
  gl.BindFramebuffer(GL_FRAMEBUFFER, r.shadow_fbo.id());
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, r.shadow_map.id(), 0);
  const GLenum none = GL_NONE;
  gl.DrawBuffers(1, &none);
  gl.ReadBuffer(GL_NONE);
  if (auto e = check_framebuffer(gl, "shadow map"); !e) return e;
  r.shadow_size = size;
  return check_gl(gl, "allocating the shadow map");
}

void shadow_pass(Renderer::Impl& r, const GpuScene& g, const Scene& s) {
  const GlApi& gl = *r.gl;
  gl.BindFramebuffer(GL_FRAMEBUFFER, r.shadow_fbo.id());
  gl.Viewport(0, 0, r.shadow_size, r.shadow_size);
  const float one = 1.0f;
  gl.ClearBufferfv(GL_DEPTH, 0, &one);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.DepthMask(GL_TRUE);
  gl.Enable(GL_POLYGON_OFFSET_FILL);
  gl.PolygonOffset(2.0f, 4.0f);  // slope-scaled bias against acne
  gl.UseProgram(r.shadow_program.id());
  for (std::size_t i = 0; i < s.instances.size(); ++i)
    if (s.materials[s.instances[i].material].alpha_mode != AlphaMode::blend) draw_instance(r, g, s, i, true);
  gl.Disable(GL_POLYGON_OFFSET_FILL);
}

void lit_pass(Renderer::Impl& r, const GpuScene& g, const Scene& s, const Camera& cam, Vec3 background,
              bool environment_background) {
  const GlApi& gl = *r.gl;
  const Targets& t = r.targets;
  gl.BindFramebuffer(GL_FRAMEBUFFER, t.samples > 1 ? t.msaa_fbo.id() : t.fbo.id());
  gl.Viewport(0, 0, t.width, t.height);
  const float clear[4] = {float(background.x), float(background.y), float(background.z), 1.0f};
  const float one = 1.0f;
  gl.ClearBufferfv(GL_COLOR, 0, clear);
  gl.ClearBufferfv(GL_DEPTH, 0, &one);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.DepthMask(GL_TRUE);
  gl.Disable(GL_BLEND);
  gl.UseProgram(r.lit_program.id());
  gl.ActiveTexture(GL_TEXTURE0 + gpu::kUnitShadow);
  gl.BindTexture(GL_TEXTURE_2D, r.shadow_map ? r.shadow_map.id() : 0);
  gl.ActiveTexture(GL_TEXTURE0 + gpu::kUnitAmbientLut);
  gl.BindTexture(GL_TEXTURE_2D, r.ambient_lut.id());
  std::vector<std::pair<double, std::size_t>> blended;
  for (std::size_t i = 0; i < s.instances.size(); ++i) {
    if (s.materials[s.instances[i].material].alpha_mode == AlphaMode::blend) {
      const Vec3 c = s.instances[i].transform.transform_point({0, 0, 0});
      blended.push_back({-length(c - cam.position), i});
      continue;
    }
    draw_instance(r, g, s, i, false);
  }
  if (environment_background) {
    background_pass(r);
    gl.UseProgram(r.lit_program.id());
  }
  if (blended.empty()) return;
  std::sort(blended.begin(), blended.end());  // far to near
  gl.Enable(GL_BLEND);
  gl.BlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
  gl.DepthMask(GL_FALSE);
  for (const auto& b : blended) draw_instance(r, g, s, b.second, false);
  gl.DepthMask(GL_TRUE);
  gl.Disable(GL_BLEND);
}

void resolve_pass(Renderer::Impl& r, double weight_exposure) {
  const GlApi& gl = *r.gl;
  const Targets& t = r.targets;
  gl.BindFramebuffer(GL_FRAMEBUFFER, t.fbo.id());
  gl.Viewport(0, 0, t.width, t.height);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_BLEND);
  gl.UseProgram(r.resolve_program.id());
  gl.Uniform1i(r.resolve_samples_loc, t.samples);
  gl.Uniform1f(r.resolve_exposure_loc, static_cast<float>(weight_exposure));
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D_MULTISAMPLE, t.msaa_color.id());
  gl.BindVertexArray(r.empty_vao.id());
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
}

// Reads an RGBA32F/RGBA16F framebuffer as float (GL rows are bottom-up), times `scale`.
Image read_rgba(const GlApi& gl, GLuint fbo, int width, int height, double scale) {
  Image img(width, height);
  gl.BindFramebuffer(GL_FRAMEBUFFER, fbo);
  gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
  gl.ReadPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, img.rgba.data());
  const std::size_t row = static_cast<std::size_t>(width) * 4;
  std::vector<float> tmp(row);
  for (int y = 0; y < height / 2; ++y) {
    float* a = img.rgba.data() + static_cast<std::size_t>(y) * row;
    float* b = img.rgba.data() + static_cast<std::size_t>(height - 1 - y) * row;
    std::memcpy(tmp.data(), a, row * sizeof(float));
    std::memcpy(a, b, row * sizeof(float));
    std::memcpy(b, tmp.data(), row * sizeof(float));
  }
  const auto s = static_cast<float>(scale);
  for (std::size_t i = 0; i < img.rgba.size(); i += 4) {
    img.rgba[i] *= s;
    img.rgba[i + 1] *= s;
    img.rgba[i + 2] *= s;
    img.rgba[i + 3] = 1.0f;
  }
  return img;
}

// Block means for metering: 1/kMeteringBlock^2 of the pixels, absolute cd/m2.
Result<Image> read_reduced(Renderer::Impl& r, double pre_exposure) {
  const GlApi& gl = *r.gl;
  const Targets& t = r.targets;
  const int w = (t.width + kMeteringBlock - 1) / kMeteringBlock, h = (t.height + kMeteringBlock - 1) / kMeteringBlock;
  if (!r.reduced || r.reduced_width != w || r.reduced_height != h) {
    r.reduced = gen_texture(gl);
    gl.BindTexture(GL_TEXTURE_2D, r.reduced.id());
    gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, w, h);
    r.reduced_fbo = gen_framebuffer(gl);
    gl.BindFramebuffer(GL_FRAMEBUFFER, r.reduced_fbo.id());
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r.reduced.id(), 0);
    if (auto e = check_framebuffer(gl, "metering target"); !e) return e.error();
    r.reduced_width = w;
    r.reduced_height = h;
  }
  gl.BindFramebuffer(GL_FRAMEBUFFER, r.reduced_fbo.id());
  gl.Viewport(0, 0, w, h);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_BLEND);
  gl.UseProgram(r.reduce_program.id());
  gl.Uniform1i(r.reduce_block_loc, kMeteringBlock);
  gl.Uniform2i(r.reduce_size_loc, t.width, t.height);
  gl.Uniform1f(r.reduce_scale_loc, static_cast<float>(1.0 / pre_exposure));
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D, t.color.id());
  gl.BindVertexArray(r.empty_vao.id());
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  return read_rgba(gl, r.reduced_fbo.id(), w, h, 1.0);
}

Result<void> check_settings(const RenderSettings& s) {
  if (auto r = check_image_size(s.width, s.height); !r)
    return make_error(r.error().code, r.error().message, "width");
  if (s.samples < 1 || s.samples > kMaxSamples)
    return make_error("render.samples", fmt::format("samples {} is not in [1, {}]", s.samples, kMaxSamples),
                      "samples");
  if (s.shadow_map_size < 256 || s.shadow_map_size > 8192)
    return make_error("render.shadow_map", "shadow map size must be in [256, 8192]", "shadow_map_size");
  return {};
}

int pick_samples(const GlApi& gl, const RenderSettings& s, std::vector<std::string>& warnings) {
  if (s.samples <= 1) return 1;
  const auto counts = supported_sample_counts(gl, s.target == TargetFormat::rgba16f ? GL_RGBA16F : GL_RGBA32F);
  int pick = 1;
  for (int c : counts)
    if (c >= s.samples) { pick = c; break; }
  if (pick == 1 && !counts.empty()) pick = counts.back();
  if (pick != s.samples)
    warnings.push_back(fmt::format("{} MSAA samples requested; the driver offers {}, using {}", s.samples,
                                   counts.empty() ? std::string("none") : fmt::format("{}", fmt::join(counts, "/")),
                                   pick));
  return pick;
}

// Light-based exposure of "a white card = 1" (REFERENCE.md §1.2: scale = pi / E).
double white_card_scale(double dominant_lux) { return dominant_lux > 0 ? kPi / dominant_lux : 0.01; }

// The frame's environment: its textures, the world -> environment rotation, its scale.
struct FrameEnvironment {
  const GpuEnvironment* gpu = nullptr;
  Mat4 world_to_env;
  double scale = 1;
  MeteredEnvironment metered() const { return {gpu ? &gpu->lighting.irradiance : nullptr, world_to_env, scale}; }
};

// Prepares the scene's environment (if any) and adds the sky's sun to its lights.
Result<FrameEnvironment> setup_environment(Renderer::Impl& r, Scene& scene, RenderResult& out) {
  FrameEnvironment env;
  if (!scene.environment) return env;
  const EnvironmentSpec& spec = *scene.environment;
  auto gpu = prepare_environment(r, spec, out.environment_ms);
  if (!gpu) return gpu.error();
  env.gpu = *gpu;
  env.scale = spec.scale;
  // The sky is built with its sun at azimuth 0: its azimuth turns it like rotation_deg.
  env.world_to_env = environment_rotation(spec.rotation_deg + (spec.sky ? spec.sky->sun_azimuth_deg : 0.0));
  out.environment = env.gpu->lighting.description;
  for (const auto& w : env.gpu->lighting.warnings) out.warnings.push_back(w);
  if (const auto& sun = env.gpu->lighting.sun) {
    if (static_cast<int>(scene.lights.size()) >= SceneLimits{}.max_lights)
      return make_error("scene.invalid", fmt::format("environment.sky: the sun would exceed the limit of {} lights",
                                                     SceneLimits{}.max_lights), "environment.sky");
    Light l;
    l.name = "sun";
    l.type = LightType::directional;
    l.direction = -transpose(env.world_to_env).transform_dir(sun->direction);
    l.illuminance_lux = sun->illuminance_lux * spec.scale;
    l.color = sun->color;
    scene.lights.push_back(l);
  }
  return env;
}

void fill_environment(gpu::FrameBlock& frame, const FrameEnvironment& env, const Scene& scene, const Camera& cam,
                      int height) {
  frame.ambient_nits = to_gpu(scene.ambient_nits.value_or(Vec3{}), scene.ambient_nits ? 1 : 0);
  const int mode = env.gpu ? gpu::kEnvMap : scene.ambient_nits ? gpu::kEnvUniform : gpu::kEnvNone;
  if (!env.gpu) {
    frame.env_params = {1, 0, float(mode), 0};
    return;
  }
  frame.env_rotation = to_gpu(env.world_to_env);
  // Background LOD: a pixel's angle at the centre of the view against a map texel's at the equator.
  const double pixel_rad = 2 * std::tan(cam.yfov_rad / 2) / height, texel_rad = 2 * kPi / env.gpu->background_width;
  frame.env_params = {float(env.scale), float(env.gpu->specular_levels - 1), float(mode),
                      float(std::max(0.0, std::log2(pixel_rad / texel_rad)))};
  if (const auto& sun = env.gpu->lighting.sun) {
    const Vec3 d = transpose(env.world_to_env).transform_dir(sun->direction);
    frame.sun_disc = to_gpu(d, std::cos(sun->angular_radius_rad));
    frame.sun_radiance = to_gpu(sun->color * (sun->disc_luminance_nits * env.scale), 1);
  }
}

void warn_about_range(const FrameEnvironment& env, const Scene& scene, const RenderSettings& settings,
                      double pre_exposure, std::vector<std::string>& warnings) {
  if (scene.ambient_nits || env.gpu)
    for (const Material& m : scene.materials)
      if (m.fresnel_exponent != 5.0) {
        warnings.push_back("environment light assumes the Schlick exponent 5 (materials with another "
                           "fresnel_power get exponent-5 environment reflection)");
        break;
      }
  if (!env.gpu || settings.target != TargetFormat::rgba16f || scene.background_nits) return;
  const double brightest = env.gpu->lighting.max_luminance_nits * env.scale;
  if (brightest * pre_exposure > kHalfMax)
    warnings.push_back(fmt::format("the environment's brightest radiance ({:.3g} cd/m2{}) exceeds the RGBA16F target "
                                   "at this exposure: clamped to {:.3g} cd/m2",
                                   brightest, env.gpu->lighting.sun ? ", the sun disc" : "", kHalfMax / pre_exposure));
}

}  // namespace

Result<RenderResult> Renderer::render(Scene scene, const RenderSettings& settings) {
  if (auto r = check_settings(settings); !r) return r.error();
  if (auto r = validate(scene); !r) return r.error();
  return render_scene(scene, settings, 0);
}

Result<RenderResult> Renderer::render_scene(Scene& scene, const RenderSettings& settings, std::uint64_t scene_id) {
  RenderResult out;
  out.scene_name = scene.name;
  out.warnings = scene.warnings;
  out.backend = context_->backend_name();
  out.gl_renderer = context_->gl_renderer();
  out.gl_version = context_->gl_version();
  out.camera = resolve_camera(scene, settings);
  if (auto r = validate_camera(out.camera); !r) return r.error();
  scene.camera = out.camera;
  for (const auto& inst : scene.instances) out.triangles += scene.meshes[inst.mesh].indices.size() / 3;

  CurrentContext current(*context_);
  if (!current.status()) return current.status().error();
  Impl& r = *impl_;
  const GlApi& gl = *r.gl;
  gl.GetError();
  auto env = setup_environment(r, scene, out);
  if (!env) return env.error();
  out.dominant_illuminance_lux = dominant_illuminance_lux(scene, out.camera, env->metered());

  const Bounds bounds = world_bounds(scene);
  const auto [znear, zfar] = depth_range(out.camera, bounds);
  const double aspect = double(settings.width) / settings.height;
  const int shadow_index = bounds.empty ? -1 : shadow_light(scene);
  const double pre_exposure = settings.target == TargetFormat::rgba16f ? white_card_scale(out.dominant_illuminance_lux) : 1.0;
  warn_about_range(*env, scene, settings, pre_exposure, out.warnings);

  gpu::FrameBlock frame{};
  const Mat4 view_proj = perspective(out.camera.yfov_rad, aspect, znear, zfar) *
                         look_at(out.camera.position, out.camera.target, out.camera.up);
  frame.view_proj = to_gpu(view_proj);
  frame.inv_view_proj = to_gpu(inverse(view_proj));
  if (shadow_index >= 0) {
    const ShadowFit fit = fit_shadow(scene.lights[shadow_index], bounds, out.camera, aspect, znear, zfar,
                                     settings.shadow_map_size);
    frame.light_clip = to_gpu(fit.light_clip);
    out.shadow_texel_m = fit.texel_m;
  }
  frame.camera_pos = to_gpu(out.camera.position, 1);
  fill_environment(frame, *env, scene, out.camera, settings.height);
  frame.params = {float(pre_exposure), float(scene.medium_ior), float(scene.lights.size()), shadow_index >= 0 ? 1.0f : 0.0f};
  frame.shadow_params = {float(kShadowNormalOffsetTexels * out.shadow_texel_m), 1.0f / settings.shadow_map_size,
                         settings.target == TargetFormat::rgba16f ? kHalfMax : 3.0e38f, 0};
  frame.options = {settings.energy_compensation ? 1.0f : 0.0f, 0, 0, 0};
  const bool environment_background = env->gpu && !scene.background_nits;
  const Vec3 background = scene.background_nits.value_or(scene.ambient_nits.value_or(Vec3{})) * pre_exposure;

  const int samples = pick_samples(gl, settings, out.warnings);
  out.samples = samples;
  if (auto e = ensure_targets(r, settings, samples); !e) {
    r.targets = Targets{};
    return e.error();
  }
  if (shadow_index >= 0)
    if (auto e = ensure_shadow_map(r, settings.shadow_map_size); !e) return e.error();

  const auto t0 = Clock::now();
  // A scene loaded for an earlier frame keeps its meshes and textures on the GPU; only
  // the frame's uniform blocks (camera, lights, instance transforms) are new.
  GpuScene local;
  GpuScene* g = scene_id != 0 ? &r.gpu_scene : &local;
  if (scene_id == 0 || r.gpu_scene_id != scene_id) {
    r.gpu_scene = GpuScene{};
    r.gpu_scene_id = 0;
    if (auto e = upload_geometry(r, scene, *g); !e) return e.error();
    r.gpu_scene_id = scene_id;
  }
  if (auto e = upload_blocks(r, scene, frame, light_block(scene, shadow_index), *g); !e) return e.error();
  if (shadow_index >= 0) shadow_pass(r, *g, scene);
  bind_environment(r, env->gpu);
  lit_pass(r, *g, scene, out.camera, background, environment_background);
  if (samples > 1)
    resolve_pass(r, settings.resolve == MsaaResolve::box ? 0.0
                                                         : white_card_scale(out.dominant_illuminance_lux) / pre_exposure);
  gl.Finish();
  out.render_ms = ms_since(t0);
  if (auto e = check_gl(gl, "rendering"); !e) return e.error();

  const auto t1 = Clock::now();
  if (settings.readback == Readback::full) {
    out.scene_nits = read_rgba(gl, r.targets.fbo.id(), r.targets.width, r.targets.height, 1.0 / pre_exposure);
  } else {
    auto reduced = read_reduced(r, pre_exposure);
    if (!reduced) return reduced.error();
    out.metering_nits = std::move(*reduced);
  }
  out.readback_ms = ms_since(t1);
  if (auto e = check_gl(gl, "reading the frame back"); !e) return e.error();
  r.has_frame = true;
  r.last_pre_exposure = pre_exposure;
  gl.BindVertexArray(0);
  gl.UseProgram(0);
  return out;
}

void Renderer::release_frame_targets() {
  CurrentContext current(*context_);
  if (!current.status()) return;  // no context: nothing can be deleted, nothing was made
  Impl& r = *impl_;
  const GlApi& gl = *r.gl;
  r.targets = Targets{};
  r.reduced = GlName{};
  r.reduced_fbo = GlName{};
  r.reduced_width = r.reduced_height = 0;
  r.has_frame = false;

  // Deleting the names is not enough: Mesa's state tracker keeps the last draw's
  // framebuffer surfaces and sampler views referenced until another draw replaces them
  // (measured on llvmpipe: a 1080p 4x MSAA frame's 200 MiB stayed until the next frame of
  // another size). So one draw into a 1x1 target, sampling a 1x1 texture on unit 0 (where
  // the resolve pass sampled the MSAA colour), drops those references; then both go.
  {
    GlName target = gen_texture(gl), source = gen_texture(gl), fbo = gen_framebuffer(gl), depth = gen_renderbuffer(gl);
    for (const GlName* t : {&target, &source}) {
      gl.BindTexture(GL_TEXTURE_2D, t->id());
      gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, 1, 1);
    }
    gl.BindRenderbuffer(GL_RENDERBUFFER, depth.id());
    gl.RenderbufferStorageMultisample(GL_RENDERBUFFER, 0, GL_DEPTH_COMPONENT32F, 1, 1);
    gl.BindFramebuffer(GL_FRAMEBUFFER, fbo.id());
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target.id(), 0);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id());
    gl.Viewport(0, 0, 1, 1);
    gl.Enable(GL_DEPTH_TEST);
    gl.UseProgram(r.reduce_program.id());
    gl.ActiveTexture(GL_TEXTURE0);
    gl.BindTexture(GL_TEXTURE_2D, source.id());
    gl.BindVertexArray(r.empty_vao.id());
    for (int i = 0; i < 4; ++i) {  // llvmpipe keeps a few binned scenes; cycle through them
      gl.DrawArrays(GL_TRIANGLES, 0, 3);
      gl.Finish();
    }
    gl.Disable(GL_DEPTH_TEST);
    gl.BindVertexArray(0);
    gl.UseProgram(0);
    gl.BindTexture(GL_TEXTURE_2D, 0);
    gl.BindRenderbuffer(GL_RENDERBUFFER, 0);
    gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  }
  gl.Finish();
}

Result<Image> Renderer::read_frame() {
  Impl& r = *impl_;
  if (!r.has_frame) return make_error("render.no_frame", "nothing rendered yet");
  CurrentContext current(*context_);
  if (!current.status()) return current.status().error();
  Image img = read_rgba(*r.gl, r.targets.fbo.id(), r.targets.width, r.targets.height, 1.0 / r.last_pre_exposure);
  if (auto e = check_gl(*r.gl, "reading the frame back"); !e) return e.error();
  return img;
}

namespace {

// What identifies a loaded scene: its source (a file by path, size and modification time,
// so an edited file is loaded again; JSON text as written) and every load option.
std::string scene_cache_key(const RenderRequest& request, const SceneLoadOptions& load) {
  std::string source;
  if (request.scene_json) {
    source = "json:" + request.scene_json->dump();
  } else {
    const std::string name = request.scene.empty() ? default_scene_name() : request.scene;
    source = "scene:" + name;
    if (!is_builtin_scene(name)) {
      const std::filesystem::path given(name);
      const std::filesystem::path path = given.is_absolute() ? given : load.base_dir / given;
      std::error_code ec;
      const auto size = std::filesystem::file_size(path, ec);
      const auto mtime = std::filesystem::last_write_time(path, ec);
      source += fmt::format(":{}:{}", ec ? 0 : size, ec ? 0 : mtime.time_since_epoch().count());
    }
  }
  const SceneLimits& l = load.limits;
  return fmt::format("{}|{}|{}|{}|{}|{},{},{},{},{},{}", source, load.base_dir.string(), load.allow_files,
                     load.gltf_emissive_nits, load.default_rig, l.max_lights, l.max_triangles, l.max_instances,
                     l.max_materials, l.max_textures, l.max_texture_bytes);
}

bool backend_matches(Backend want, const std::string& have) {
  switch (want) {
    case Backend::automatic: return true;
    case Backend::egl: return have.rfind("egl", 0) == 0;
    case Backend::egl_device: return have == "egl-device";
    case Backend::egl_surfaceless: return have == "egl-surfaceless";
    case Backend::osmesa: return have == "osmesa";
  }
  return false;
}
}  // namespace

Result<RenderResult> Renderer::render(const RenderRequest& request) {
  if (!backend_matches(request.backend, backend_name()))
    return make_error("render.backend",
                      fmt::format("this renderer runs on {}, the request asks for {}", backend_name(),
                                  to_string(request.backend)),
                      "backend");
  RenderSettings settings;
  settings.width = request.width;
  settings.height = request.height;
  settings.samples = request.samples;
  settings.camera = request.camera;
  settings.target = request.target;
  settings.readback = request.readback;
  settings.energy_compensation = request.energy_compensation;
  if (auto r = check_settings(settings); !r) return r.error();  // before any loading work
  if (request.environment)
    if (auto r = validate_environment_spec(*request.environment); !r) return r.error();
  if (!std::isfinite(request.time_s) || std::abs(request.time_s) > 1e9 ||
      (request.previous_time_s && !std::isfinite(*request.previous_time_s)))
    return make_error("render.time_s", fmt::format("time_s {} is not a finite time in seconds", request.time_s), "time_s");
  SceneLoadOptions load = request.load;
  if (request.environment) load.default_rig = false;  // the environment lights the model
  Impl& r = *impl_;
  const std::string key = scene_cache_key(request, load);
  const bool reused = r.scene_cache && r.scene_cache->key == key;
  double load_ms = 0;
  if (!reused) {
    release_scene();
    const auto t0 = Clock::now();
    auto scene = request.scene_json ? parse_scene_json(*request.scene_json, load)
                                    : load_scene(request.scene.empty() ? default_scene_name() : request.scene, load);
    if (!scene) return scene.error();
    if (auto v = validate(*scene); !v) return v.error();
    CachedScene c;
    c.key = key;
    c.id = ++r.scene_ids;
    c.instances = scene->instances;
    c.lights = scene->lights;
    c.camera = scene->camera;
    c.environment = scene->environment;
    c.ambient_nits = scene->ambient_nits;
    c.warnings = scene->warnings;
    c.scene = std::move(*scene);
    r.scene_cache = std::move(c);
    ++r.scene_loads;
    load_ms = ms_since(t0);
  }
  CachedScene& cached = *r.scene_cache;
  cached.restore();
  Scene& scene = cached.scene;
  if (request.environment) {
    // The request's environment replaces the scene's, its sun included (the sky's sun is
    // added at render time, never stored in the scene's lights).
    scene.environment = request.environment;
    scene.ambient_nits.reset();
  }
  AnimatedFrame posed;
  if (scene.animation) {
    auto a = animate(scene, *scene.animation, request.time_s, request.previous_time_s);
    if (!a) return a.error();
    posed = *a;
  }
  auto out = render_scene(scene, settings, cached.id);
  if (!out) return out;
  if (const auto& anim = scene.animation) {
    out->duration_s = anim->duration_s();
    if (anim->camera) out->cut_times_s = anim->camera->cut_times_s;
  }
  out->exposure_ev100 = posed.exposure_ev100;
  out->exposure_compensation_ev = posed.exposure_compensation_ev;
  out->scene_cut = posed.scene_cut;
  out->scene_reused = reused;
  out->scene_load_ms = load_ms;
  return out;
}

void Renderer::release_scene() {
  Impl& r = *impl_;
  r.scene_cache.reset();
  if (r.gpu_scene_id == 0 && r.gpu_scene.meshes.empty()) return;
  CurrentContext current(*context_);
  if (!current.status()) return;
  r.gpu_scene = GpuScene{};
  r.gpu_scene_id = 0;
}

std::uint64_t Renderer::scene_loads() const { return impl_->scene_loads; }

}  // namespace hdrd::shading

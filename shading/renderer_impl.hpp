// Renderer internals shared by renderer.cpp, gpu_scene.cpp and gpu_pass.cpp.
#pragma once

#include <map>
#include <optional>
#include <vector>

#include "shading/gl_util.hpp"
#include "shading/gpu_blocks.hpp"
#include "shading/renderer.hpp"

namespace hdrd::shading {

// Render targets, kept between frames of the same size/format/samples.
struct Targets {
  int width = 0, height = 0, samples = 0;
  TargetFormat format = TargetFormat::rgba32f;
  GlName msaa_color, msaa_depth, msaa_fbo;  // only when samples > 1
  GlName color, depth, fbo;                 // single-sample result (resolve target)
};

struct GpuMesh {
  GlName vao, vbo, ibo;
  GLsizei index_count = 0;
};

// A scene on the GPU: meshes and textures (kept between frames of the same loaded scene)
// and the uniform blocks of one frame.
struct GpuScene {
  std::vector<GpuMesh> meshes;
  std::map<int, GlName> textures;  // key: texture index * 2 + (sRGB ? 1 : 0)
  GlName frame_ubo, light_ubo, draw_ubo;
  std::size_t draw_stride = 0;
  bool has_shadow = false;
};

// An environment on the GPU, kept between frames (one per renderer: the last one used).
struct GpuEnvironment {
  std::string key;                 // environment_cache_key()
  EnvironmentLighting lighting;    // its map is released once uploaded
  GlName background;               // the equirectangular map, RGBA32F with mips
  int background_width = 0;
  GlName specular;                 // GGX-prefiltered cube map, roughness = LOD / (levels - 1)
  int specular_levels = 0;
  GlName irradiance;               // irradiance cube map, lux
};

// The last scene loaded by render(RenderRequest), in its rest pose, and what a frame
// changes in it (posing, the sky's sun, the request's environment), restored each frame.
struct CachedScene {
  std::string key;  // scene_cache_key(): the source (and a file's size and mtime) and the load options
  std::uint64_t id = 0;
  Scene scene;
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::optional<Camera> camera;
  std::optional<EnvironmentSpec> environment;
  std::optional<Vec3> ambient_nits;
  std::vector<std::string> warnings;
  void restore() {
    scene.instances = instances;
    scene.lights = lights;
    scene.camera = camera;
    scene.environment = environment;
    scene.ambient_nits = ambient_nits;
    scene.warnings = warnings;
  }
};

struct Renderer::Impl {
  GlContext* context = nullptr;
  const GlApi* gl = nullptr;
  GlName lit_program, shadow_program, resolve_program, reduce_program;
  GLint resolve_samples_loc = -1, resolve_exposure_loc = -1;
  GLint reduce_block_loc = -1, reduce_size_loc = -1, reduce_scale_loc = -1;
  GlName reduced, reduced_fbo;  // the block-mean target of Readback::reduced
  int reduced_width = 0, reduced_height = 0;
  GlName ambient_lut, white_texture, empty_vao;
  GLint ubo_alignment = 256;
  Targets targets;
  GlName shadow_map, shadow_fbo;
  int shadow_size = 0;
  bool has_frame = false;  // targets.color holds the last rendered frame
  double last_pre_exposure = 1.0;
  // Environment light (ibl.cpp).
  GlName background_program, cube_program, prefilter_program;
  std::optional<GpuEnvironment> environment;
  // Scene reuse between frames (render(RenderRequest)): the loaded scene and its
  // geometry on the GPU (gpu_scene_id: the CachedScene::id it holds; 0: none).
  std::optional<CachedScene> scene_cache;
  std::uint64_t scene_ids = 0, scene_loads = 0;
  GpuScene gpu_scene;
  std::uint64_t gpu_scene_id = 0;
};

// ibl.cpp: programs at start-up; an environment's textures (built, or the cached ones
// when the key matches), adding the time spent to `spent_ms`; the background pass.
Result<void> init_ibl(Renderer::Impl& r);
Result<const GpuEnvironment*> prepare_environment(Renderer::Impl& r, const EnvironmentSpec& spec, double& spent_ms);
void bind_environment(Renderer::Impl& r, const GpuEnvironment* env);
void background_pass(Renderer::Impl& r);

// gpu_scene.cpp: a scene's meshes and textures; a frame's uniform blocks (bound).
Result<void> upload_geometry(Renderer::Impl& r, const Scene& scene, GpuScene& g);
Result<void> upload_blocks(Renderer::Impl& r, const Scene& scene, const gpu::FrameBlock& frame,
                           const gpu::LightBlock& lights, GpuScene& g);
// Binds textures and the draw block of instance i, and draws it.
void draw_instance(Renderer::Impl& r, const GpuScene& g, const Scene& scene, std::size_t i, bool depth_only);

// Sample counts the driver offers for a colour format, ascending.
std::vector<int> supported_sample_counts(const GlApi& gl, GLenum internal_format);

}  // namespace hdrd::shading

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

// A scene on the GPU for one frame.
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
};

// ibl.cpp: programs at start-up; an environment's textures (built, or the cached ones
// when the key matches), adding the time spent to `spent_ms`; the background pass.
Result<void> init_ibl(Renderer::Impl& r);
Result<const GpuEnvironment*> prepare_environment(Renderer::Impl& r, const EnvironmentSpec& spec, double& spent_ms);
void bind_environment(Renderer::Impl& r, const GpuEnvironment* env);
void background_pass(Renderer::Impl& r);

// gpu_scene.cpp
Result<GpuScene> upload_scene(Renderer::Impl& r, const Scene& scene, const gpu::FrameBlock& frame,
                              const gpu::LightBlock& lights);
// Binds textures and the draw block of instance i, and draws it.
void draw_instance(Renderer::Impl& r, const GpuScene& g, const Scene& scene, std::size_t i, bool depth_only);

// Sample counts the driver offers for a colour format, ascending.
std::vector<int> supported_sample_counts(const GlApi& gl, GLenum internal_format);

}  // namespace hdrd::shading

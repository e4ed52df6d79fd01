// The offscreen renderer: one GL context per Renderer, used from one thread at a time
// (the daemon keeps one per worker). render() loads a scene (built-in name, file, or a
// JSON document), shades it physically and returns the scene-referred frame: linear
// Rec.709 primaries, absolute cd/m2, float32, rows top-down.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/image.hpp"
#include "encode/result.hpp"
#include "shading/gl_context.hpp"
#include "shading/scene.hpp"
#include "shading/scene_loader.hpp"

namespace hdrd::shading {

struct CameraOverride {
  std::optional<Vec3> position;
  std::optional<Vec3> target;
  std::optional<double> yfov_deg;
};
// "px,py,pz[:tx,ty,tz[:fov_deg]]", e.g. "0,1.5,6:0,0.5,0:40".
Result<CameraOverride> parse_camera_override(std::string_view text);

// RGBA32F keeps absolute cd/m2 exactly; RGBA16F renders pre-exposed (white card = 1)
// and clamps at 65504 times that.
enum class TargetFormat { rgba32f, rgba16f };

inline constexpr int kMaxSamples = 16;

enum class Readback { full, reduced };
inline constexpr int kMeteringBlock = 8;  // reduced readback: 8x8 block means (1/64 of the bytes)

// How MSAA samples become a pixel. tonemap_weighted (default): weights 1 / (1 + L), with
// L the sample's luminance in "white card = 1" units (pi / E of the dominant light), so
// the result is the inverse Reinhard of the mean Reinhard-mapped sample (RTR4 §5.4.2,
// Karis 2014) and edges survive tone mapping. box: plain average (for comparison).
enum class MsaaResolve { tonemap_weighted, box };

struct RenderSettings {
  int width = 1280;
  int height = 720;
  int samples = 4;  // MSAA; 1 = off. Clamped to what the driver offers (warning).
  std::optional<CameraOverride> camera;
  TargetFormat target = TargetFormat::rgba32f;
  MsaaResolve resolve = MsaaResolve::tonemap_weighted;
  int shadow_map_size = 2048;
  // Multiple-scattering GGX energy compensation (Kulla & Conty 2017 for punctual lights,
  // Fdez-Aguera 2019 for environment light); false: single scattering, for comparison.
  bool energy_compensation = true;
  // full: read the float frame back (scene_nits). reduced: read back only block means of
  // kMeteringBlock x kMeteringBlock pixels (metering_nits), e.g. to meter exposure when the
  // frame is encoded on the GPU; read_frame() can still fetch the full frame afterwards.
  Readback readback = Readback::full;
};

struct RenderRequest {
  std::string scene;  // built-in name or a .gltf/.glb/.json path; empty: scene_json, else the default scene
  std::optional<nlohmann::json> scene_json;
  int width = 1280;
  int height = 720;
  int samples = 4;
  std::optional<CameraOverride> camera;
  Backend backend = Backend::automatic;  // for Renderer::create; render() checks it matches
  TargetFormat target = TargetFormat::rgba32f;
  Readback readback = Readback::full;
  SceneLoadOptions load;
  // Replaces the scene's environment and ambient term (and the sky's sun). A glTF file
  // rendered with an environment gets exactly its own lights plus it (no default rig).
  std::optional<EnvironmentSpec> environment;
  bool energy_compensation = true;
  // Scene time of the frame, seconds: the scene's animation is sampled here (clamped to
  // its keys). The same request at the same time gives the identical frame.
  double time_s = 0;
  // The frame before in a sequence: a cut keyframe in (previous_time_s, time_s] sets
  // RenderResult::scene_cut. Unset: only a cut within 1 us before time_s does.
  std::optional<double> previous_time_s;
};

struct RenderResult {
  Image scene_nits;     // linear Rec.709, cd/m2, RGBA float32 (A = 1), rows top-down (Readback::full)
  Image metering_nits;  // Readback::reduced: kMeteringBlock^2 block means, same units
  std::string scene_name;
  std::string backend;      // "egl-device", "egl-surfaceless", "osmesa"
  std::string gl_renderer;  // GL_RENDERER
  std::string gl_version;   // GL_VERSION
  int samples = 1;          // MSAA samples used
  double render_ms = 0;     // GPU work (shadow + main pass + resolve), glFinish-bounded
  double readback_ms = 0;
  // Loading and prefiltering the environment (CPU and GPU); 0 when reused from an earlier frame.
  double environment_ms = 0;
  double dominant_illuminance_lux = 0;  // for light-based exposure (pi / E); 0 if none
  std::string environment;              // what lit the frame: a file name or the sky's parameters; empty: none
  double shadow_texel_m = 0;            // world size of a shadow-map texel (0: no shadow map)
  Camera camera;                         // the camera used
  std::int64_t triangles = 0;
  std::vector<std::string> warnings;
  // The scene's keyframed exposure at time_s (JSON scenes' "keyframes.exposure"); unset
  // when the scene has none.
  std::optional<double> exposure_ev100;
  std::optional<double> exposure_compensation_ev;
  double duration_s = 0;      // the scene's animation length: its last key time (0: a still scene)
  bool scene_cut = false;     // a camera keyframe marked "cut" lies at this frame (see previous_time_s)
  std::vector<double> cut_times_s;  // every cut keyframe's time
  // Scene reuse: false when this frame loaded (parsed, built, uploaded) the scene, true
  // when it reused the one loaded for an earlier frame; scene_load_ms: that loading.
  bool scene_reused = false;
  double scene_load_ms = 0;
};

class Renderer {
 public:
  static Result<std::unique_ptr<Renderer>> create(Backend backend = Backend::automatic);
  static Result<std::unique_ptr<Renderer>> create(const ContextOptions& options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Loads the request's scene and renders it.
  Result<RenderResult> render(const RenderRequest& request);
  // Renders an already built scene (validated and possibly modified: degenerate
  // triangles dropped, missing normals computed).
  Result<RenderResult> render(Scene scene, const RenderSettings& settings);

  // The full float frame of the last render (e.g. after a reduced readback).
  Result<Image> read_frame();

  // Frees the render targets kept for the next frame of the same size (and the last
  // frame with them: read_frame() and post passes need a new render). A service calls it
  // after a large frame, whose targets (20 B/px, and as much again per MSAA sample) would
  // otherwise stay resident until a frame of another size.
  void release_frame_targets();

  // Frees the scene kept for the next frame (CPU copy and GPU meshes and textures).
  void release_scene();
  // How many times render(RenderRequest) has loaded a scene (not counting reuse).
  std::uint64_t scene_loads() const;

  const GlContext& context() const { return *context_; }
  std::string backend_name() const { return context_->backend_name(); }

  struct Impl;
  // The last rendered frame stays on the GPU for post passes (gpu_pass.hpp).
  Impl& impl() { return *impl_; }

 private:
  Renderer(std::unique_ptr<GlContext> c, std::unique_ptr<Impl> impl);
  // Renders a validated scene in place (it gets the camera used and the sky's sun);
  // scene_id != 0: its meshes and textures may be reused from the frame before.
  Result<RenderResult> render_scene(Scene& scene, const RenderSettings& settings, std::uint64_t scene_id);
  std::unique_ptr<GlContext> context_;
  std::unique_ptr<Impl> impl_;
};

// Dynamic range of a frame in stops: log2 of the ratio of the luminance at the
// `high` and `low` quantiles of the pixels with non-zero luminance.
double dynamic_range_stops(const Image& frame, double low = 0.001, double high = 0.999);

}  // namespace hdrd::shading

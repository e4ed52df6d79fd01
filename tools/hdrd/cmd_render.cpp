// hdrd render --scene NAME|FILE -o OUTBASE: shade a scene physically (absolute cd/m2),
// then encode it for a display mode like `hdrd encode` does, on the GPU when the
// pipeline allows it. Writes the scene-referred EXR as well as the usual dumps.
#include <chrono>
#include <filesystem>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "shading/gpu_encode.hpp"
#include "shading/renderer.hpp"
#include "shading/scene_loader.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/pipeline_options.hpp"

namespace hdrd::cli {
namespace {

struct RenderOptions {
  CommonOptions common;
  PipelineOptions pipeline;
  std::string scene;
  std::string outbase;
  int width = 1920;
  int height = 1080;
  int samples = 4;
  std::string camera;
  std::string backend = "auto";
  std::string encoder = "auto";
  bool no_scene_exr = false;
};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

shading::RenderResult render_scene(const RenderOptions& o, shading::Renderer& renderer, shading::Readback readback) {
  shading::RenderRequest q;
  q.readback = readback;
  q.scene = o.scene.empty() ? shading::default_scene_name() : o.scene;
  q.width = o.width;
  q.height = o.height;
  q.samples = o.samples;
  if (!o.camera.empty()) {
    auto cam = shading::parse_camera_override(o.camera);
    if (!cam) throw CliError("--camera: " + cam.error().message);
    q.camera = *cam;
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto r = renderer.render(q);
  if (!r) throw HdrdError(r.error());
  progress("rendered {} at {}x{} ({}x MSAA) on {} ({}) in {:.0f} ms", r->scene_name, o.width, o.height, r->samples,
           r->backend, r->gl_renderer, ms_since(t0));
  for (const auto& w : r->warnings) progress("warning: {}", w);
  return std::move(*r);
}

// GPU when asked or possible; the CPU for display-referred EXR dumps (the GPU program
// writes only the signal) and for what the GPU program does not cover. `in` is the full
// frame, or null when only block means were read back (then it is fetched on demand).
EncodedFrame encode(const RenderOptions& o, shading::Renderer& renderer, const Image* full,
                    const PreparedPipeline& prepared, std::vector<std::string>& notes) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool want_gpu = o.encoder == "gpu" || (o.encoder == "auto" && !prepared.settings.keep_display_nits);
  if (want_gpu) {
    auto enc = shading::GpuEncoder::create(renderer, prepared);
    if (enc) {
      auto f = (*enc)->encode();
      if (!f) throw HdrdError(f.error());
      progress("encoded {} on the GPU in {:.0f} ms (pass {:.1f} ms, readback {:.1f} ms)",
               to_string(prepared.settings.target.mode), ms_since(t0), f->gpu_ms, f->readback_ms);
      return std::move(f->frame);
    }
    if (o.encoder == "gpu") throw HdrdError(enc.error());
    notes.push_back("encoded on the CPU: " + enc.error().message);
  } else if (o.encoder == "auto") {
    notes.push_back("encoded on the CPU: the display-referred EXR dump needs the CPU path");
  }
  Image fetched;
  if (!full) {
    auto img = renderer.read_frame();
    if (!img) throw HdrdError(img.error());
    fetched = std::move(*img);
    full = &fetched;
  }
  SceneInput in;
  in.image = full;
  in.units = InputUnits::absolute;
  auto f = encode_prepared(in, prepared);
  if (!f) throw HdrdError(f.error());
  progress("encoded {} on the CPU in {:.0f} ms", to_string(prepared.settings.target.mode), ms_since(t0));
  return std::move(*f);
}

void run(const RenderOptions& o) {
  set_progress_enabled(!o.common.quiet);
  if (o.encoder != "auto" && o.encoder != "gpu" && o.encoder != "cpu")
    throw CliError("--encoder: '" + o.encoder + "' is not auto, gpu or cpu");
  const auto backend = shading::parse_backend(o.backend);
  if (!backend) throw CliError("--backend: '" + o.backend + "' is not auto, egl, egl-device, egl-surfaceless or osmesa");
  std::vector<std::string> notes;
  // Renders are absolute light: automatic (histogram) metering unless told otherwise.
  EncodeSettings settings = build_settings(o.pipeline, exposure::Mode::histogram, &notes);
  const auto formats = build_formats(o.pipeline, settings.target.mode);
  const DebugOutputs debug = parse_debug(o.pipeline);
  auto wants = [&](io::DumpFormat f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
  settings.keep_display_nits = wants(io::DumpFormat::exr);
  settings.png_samples = wants(io::DumpFormat::png);

  auto renderer = shading::Renderer::create(*backend);
  if (!renderer) throw HdrdError(renderer.error());
  // Without a scene EXR or CPU-side outputs, only 8x8 block means come back for metering
  // and the frame stays on the GPU for the encode pass.
  const bool full = !o.no_scene_exr || o.encoder == "cpu" || settings.keep_display_nits;
  const shading::RenderResult r =
      render_scene(o, **renderer, full ? shading::Readback::full : shading::Readback::reduced);

  SceneInput in;
  in.image = full ? &r.scene_nits : &r.metering_nits;
  in.to_working = color::to_working(color::Space::rec709);
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  if (r.dominant_illuminance_lux > 0) in.illuminance_lux = r.dominant_illuminance_lux;
  auto prepared = prepare_pipeline(in, settings);
  if (!prepared) throw HdrdError(prepared.error());
  if (!full) notes.push_back(fmt::format("exposure metered on {}x{} block means", shading::kMeteringBlock,
                                         shading::kMeteringBlock));
  EncodedFrame frame = encode(o, **renderer, full ? &r.scene_nits : nullptr, *prepared, notes);

  const std::filesystem::path scene_exr = o.outbase + ".scene.exr";
  frame.settings["render"] = {{"scene", r.scene_name},
                              {"backend", r.backend},
                              {"gl_renderer", r.gl_renderer},
                              {"gl_version", r.gl_version},
                              {"width", o.width},
                              {"height", o.height},
                              {"samples", r.samples},
                              {"render_ms", r.render_ms},
                              {"dominant_illuminance_lux", r.dominant_illuminance_lux},
                              {"triangles", r.triangles},
                              {"warnings", r.warnings}};
  if (!o.no_scene_exr) frame.settings["render"]["scene_exr"] = scene_exr.string();

  // The scene-referred frame: float32, linear Rec.709, absolute cd/m2 (whiteLuminance 1),
  // written with the dumps (all files or none, listed in the sidecar).
  auto extra = debug_files(frame, debug);
  if (!o.no_scene_exr) {
    io::ExrWriteOptions ex;
    ex.half = false;
    ex.white_luminance = 1.0;
    ex.attributes["scene"] = r.scene_name;
    ex.attributes["units"] = "cd/m2";
    auto bytes = io::encode_exr(r.scene_nits, ex);
    if (!bytes) throw HdrdError(bytes.error());
    extra.push_back({"scene_exr", ".scene.exr", std::move(*bytes)});
  }
  auto dumps = io::write_dumps(frame, o.outbase, formats, extra);
  if (!dumps) throw HdrdError(dumps.error());
  print_out(summary_text(frame, *dumps, o.common.json, notes));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<RenderOptions>();
  auto* app = root.add_subcommand("render", "Render a scene physically and encode it for a display mode");
  app->add_option("--scene", o->scene,
                  "Built-in scene (material-grid, fresnel, furnace, hdr, underwater) or a .gltf/.glb/.json file "
                  "(default: material-grid)");
  app->add_option("-o,--output", o->outbase,
                  "Output base path: OUTBASE.png/.exr/.raw, OUTBASE.json and OUTBASE.scene.exr")
      ->required();
  app->add_option("--width", o->width, "Frame width in pixels (default 1920)");
  app->add_option("--height", o->height, "Frame height in pixels (default 1080)");
  app->add_option("--samples", o->samples, "MSAA samples, 1 = off (default 4)");
  app->add_option("--camera", o->camera, "Camera override px,py,pz[:tx,ty,tz[:fov_deg]]");
  app->add_option("--backend", o->backend, "GL backend: auto, egl, egl-device, egl-surfaceless or osmesa");
  app->add_option("--encoder", o->encoder, "auto (GPU when it can), gpu or cpu");
  app->add_flag("--no-scene-exr", o->no_scene_exr, "Do not write OUTBASE.scene.exr");
  add_pipeline_options(*app, o->pipeline);
  add_debug_option(*app, o->pipeline);
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd render --scene material-grid -o out/grid --mode hdr10 --peak 1000\n"
      "  hdrd render --scene hdr -o out/hdr --debug heatmap        (+ out/hdr.heatmap.png, display cd/m2)\n"
      "  hdrd render --scene hdr -o out/hdr-sdr --mode sdr --tonemap aces-narkowicz --format png\n"
      "  hdrd render --scene model.glb -o out/model --width 1280 --height 720 --camera 0,1.5,4:0,0.5,0:40\n"
      "  hdrd render --scene furnace -o out/f --exposure-mode light --backend osmesa --json\n"
      "The scene-referred frame (OUTBASE.scene.exr) is float32 linear Rec.709 in absolute cd/m2;\n"
      "scenes are described in docs/scene-format.md, shading in docs/rendering.md.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("render", 15, &hdrd::cli::setup)

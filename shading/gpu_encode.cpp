#include "shading/gpu_encode.hpp"

namespace hdrd::shading {
namespace {

PassOutput pass_output(gpu::TargetFormat f) {
  switch (f) {
    case gpu::TargetFormat::rg32ui: return PassOutput::rg32ui;
    case gpu::TargetFormat::rgba32ui: return PassOutput::rgba32ui;
    case gpu::TargetFormat::r32ui: break;
  }
  return PassOutput::r32ui;
}

PassProgram pass_program(const gpu::EncodeProgram& prog) {
  PassProgram p;
  p.name = "encode";
  p.output = pass_output(prog.target_format);
  p.block_name = "HdrdEncode";
  p.block_size = sizeof(gpu::EncodeUniforms);
  // The scene texel times hdrd_scene_scale is absolute cd/m2, which is the input the
  // prepared pipeline was metered and scaled for.
  p.fragment_source = prog.glsl + R"(
void main() {
  vec3 rgb = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0).rgb * hdrd_scene_scale;
  hdrd_out = hdrd_encode(rgb, hdrd_pixel());
}
)";
  for (const gpu::Table& t : prog.tables) {
    PassTexture tex;
    tex.sampler = t.sampler;
    tex.dimensions = 1;
    tex.width = static_cast<int>(t.data.size());
    tex.channels = 1;
    tex.data = t.data;
    tex.linear_filter = false;  // the GLSL interpolates itself (texelFetch)
    p.textures.push_back(std::move(tex));
  }
  if (!prog.ui.empty()) {
    PassTexture ui;
    ui.sampler = "hdrd_ui";
    ui.width = prog.ui_width;
    ui.height = prog.ui_height;
    ui.data = prog.ui;
    ui.linear_filter = false;
    p.textures.push_back(std::move(ui));
  }
  return p;
}

}  // namespace

Result<std::unique_ptr<GpuEncoder>> GpuEncoder::create(Renderer& renderer, const PreparedPipeline& prepared) {
  gpu::EncodeProgram prog = gpu::make_encode_program(prepared);
  if (!prog.supported) return make_error("gpu.unsupported", prog.unsupported_reason);
  auto pass = GpuPass::compile(renderer, pass_program(prog));
  if (!pass) return pass.error();
  return std::unique_ptr<GpuEncoder>(new GpuEncoder(prepared, std::move(prog), std::move(*pass)));
}

Result<GpuEncodeResult> GpuEncoder::finish(Result<PassResult> r) {
  if (!r) return r.error();
  auto frame = gpu::frame_from_readback(prepared_, program_, r->width, r->height, r->bytes.data(), false);
  if (!frame) return frame.error();
  GpuEncodeResult out;
  out.frame = std::move(*frame);
  out.gpu_ms = r->gpu_ms;
  out.readback_ms = r->readback_ms;
  return out;
}

Result<GpuEncodeResult> GpuEncoder::encode() { return finish(pass_->run(block_bytes(program_.uniforms))); }

Result<GpuEncodeResult> GpuEncoder::encode_image(const Image& image) {
  return finish(pass_->run_on_image(image, block_bytes(program_.uniforms)));
}

}  // namespace hdrd::shading

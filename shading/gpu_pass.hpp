// Generic full-screen GPU passes over the rendered frame: the infrastructure for the GPU
// encode pass. A pass is a fragment shader plus float lookup textures plus one std140
// uniform block, writing either float RGBA or an INTEGER target whose codes the shader
// computes itself (llvmpipe's UNORM10 stores can be 1 code off and its float->half stores
// round toward zero: platform-debian12.md §1). The result is read back at the output
// format, rows top-down.
//
// Shader contract (the source is appended to the GLSL preamble, which makes every
// sampler highp):
//   in vec2 v_uv;                                   // [0,1]^2, bottom-up
//   uniform sampler2D hdrd_scene;                   // the frame; texelFetch(ivec2(gl_FragCoord.xy))
//   uniform float hdrd_scene_scale;                 // times a texel = absolute cd/m2 (undoes pre-exposure)
//   ivec2 hdrd_pixel()                              // this pixel, rows top-down (as read back)
//   out vec4 hdrd_out;  (rgba32f)  or  out uvec4 hdrd_out;  (integer outputs)
//   uvec4 hdrd_quantize(vec4 v, float max_code)     // uint(clamp(v,0,1) * max_code + 0.5)
//   uint  hdrd_half_bits(float v)                   // packHalf2x16: round to nearest even
// plus, from the PassProgram, `uniform sampler2D/sampler3D <name>` for each table (1D
// tables are 2D textures of height 1: sample them at y = 0.5) and the uniform block,
// which the source declares itself as `layout(std140, binding = 3) uniform <block_name>`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "encode/image.hpp"
#include "encode/result.hpp"

namespace hdrd::shading {

class Renderer;

enum class PassOutput {
  rgba32f,      // float RGBA, 16 bytes per pixel
  rgba16f_bits, // GL_RGBA16UI holding half-float bits (hdrd_half_bits), 8 bytes: ABGR16161616F
  rgb10a2ui,    // GL_RGB10_A2UI, packed little-endian R in bits 0-9: XBGR2101010
  rgba8ui,      // GL_RGBA8UI, 4 bytes in R, G, B, A order
  r32ui,        // GL_R32UI: one 32-bit word the shader packs itself (a DRM pixel)
  rg32ui,       // GL_RG32UI: two words (e.g. two packHalf2x16 = ABGR16161616F)
  rgba32ui,     // GL_RGBA32UI: four words
};
std::size_t bytes_per_pixel(PassOutput o);

struct PassTexture {
  std::string sampler;  // uniform name in the shader
  int dimensions = 2;   // 1 (stored as width x 1), 2 or 3
  int width = 1, height = 1, depth = 1;
  int channels = 4;     // 1 (R32F) to 4 (RGBA32F)
  std::vector<float> data;  // width * height * depth * channels, x fastest
  bool linear_filter = true;
};

inline constexpr int kPassUniformBinding = 3;

struct PassProgram {
  std::string name = "pass";          // for error messages
  std::string fragment_source;
  std::vector<PassTexture> textures;
  std::string block_name = "Params";  // the std140 block; empty: none
  std::size_t block_size = 0;         // its C++ twin's sizeof; checked against the driver's layout
  PassOutput output = PassOutput::rgba32f;
};

struct PassResult {
  int width = 0, height = 0;
  PassOutput format = PassOutput::rgba32f;
  std::vector<std::uint8_t> bytes;  // rows top-down, tightly packed
  double gpu_ms = 0;
  double readback_ms = 0;
  const float* floats() const { return reinterpret_cast<const float*>(bytes.data()); }
  std::uint32_t word(std::size_t pixel, int index = 0) const;  // 32-bit word `index` of a pixel (all but float/half)
  std::uint16_t half(std::size_t pixel, int channel) const;  // rgba16f_bits
};

class GpuPass {
 public:
  // Compiles in the renderer's context (made current for the call).
  static Result<std::unique_ptr<GpuPass>> compile(Renderer& renderer, const PassProgram& program);
  ~GpuPass();
  GpuPass(const GpuPass&) = delete;
  GpuPass& operator=(const GpuPass&) = delete;

  // Runs over the renderer's last frame (Renderer::render must have succeeded).
  Result<PassResult> run(std::span<const std::byte> uniforms);
  // Runs over an image uploaded as RGBA32F (scale 1), e.g. for tests against the CPU.
  Result<PassResult> run_on_image(const Image& image, std::span<const std::byte> uniforms);

  struct State;

 private:
  GpuPass(Renderer& r, std::unique_ptr<State> s);
  Renderer& renderer_;
  std::unique_ptr<State> state_;
};

template <class T>
std::span<const std::byte> block_bytes(const T& block) {
  return std::as_bytes(std::span<const T, 1>(&block, 1));
}

}  // namespace hdrd::shading

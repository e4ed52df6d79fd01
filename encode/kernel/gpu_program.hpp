// The GPU encode pass, described without GL: GLSL text, a std140 uniform block with its
// C++ twin, and the lookup tables to upload. Everything comes from the CPU pipeline:
// the tone and signal tables are the very FloatBitsLut tables the CPU fast path uses
// (evaluated from the reference functions), the matrices and levels are printed from
// the prepared pipeline, and the GLSL lookup mirrors FloatBitsLut::operator(). So the
// GPU result matches encode_frame() within float rounding (tested: <= 1 code).
//
// Use: make_encode_program() -> compile `glsl` after your own `#version` line and
// `main()` (GL 4.5 core or GLES 3.x), upload `tables` as single-row R32F textures and
// `ui` as an RGBA32F texture (both sampled with texelFetch, no filtering), bind
// `uniforms` to the block `HdrdEncode` (binding kUniformBinding), call
// `uvec4 hdrd_encode(vec3 scene_rgb, ivec2 pixel)` per pixel and write the result to an
// integer target of `target_format`; then frame_from_readback() builds the EncodedFrame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "encode/frame.hpp"
#include "encode/pipeline.hpp"
#include "encode/result.hpp"

namespace hdrd::gpu {

inline constexpr int kUniformBinding = 3;

// std140 twin of `layout(std140) uniform HdrdEncode` (static_asserts in the .cpp).
struct alignas(16) EncodeUniforms {
  float m_in[12];          // mat3 = 3 column vec4s: input RGB -> working, exposure folded in
  float m_container[12];   // working -> container
  float paper_white, peak, code_scale, code_offset;
  float tone_lo, tone_hi_prev, tone_hi, signal_lo;
  float signal_hi_prev, hlg_peak, hlg_gamma, ui_dim;
  std::uint32_t tone_base, signal_base, max_code, lift_base;
  float ui_x0, ui_y0, ui_scale, gamut_lo;
  std::int32_t ui_w, ui_h, pad1, pad2;
  float tone_zero, tone_toe_slope, lift_zero, lift_toe_slope;  // ToneStage's toes
  float lift_lo, lift_hi_prev, signal_max, pad4;  // signal_max: SignalStage's (PNG samples)
};

struct Table {
  std::string sampler;      // uniform sampler2D name in the GLSL
  std::vector<float> data;  // one row; width = data.size() (<= 16384)
};

// What the integer target holds per pixel.
enum class TargetFormat {
  r32ui,     // the packed DRM word: XBGR2101010 or XRGB8888
  rgba32ui,  // x: packed word, y: 16-bit PNG samples R | G << 16, z: B
  rg32ui,    // scRGB: packHalf2x16(R, G), packHalf2x16(B, 1.0) = ABGR16161616F
};

struct EncodeProgram {
  bool supported = true;
  std::string unsupported_reason;  // when false: encode on the CPU instead
  std::string glsl;                // declarations + hdrd_encode(); no #version, no main()
  EncodeUniforms uniforms{};
  std::vector<Table> tables;
  std::vector<float> ui;           // RGBA32F overlay (premultiplied container nits), empty if none
  int ui_width = 0, ui_height = 0;
  TargetFormat target_format = TargetFormat::r32ui;
  std::uint32_t drm_fourcc = 0;
};

// The program for a prepared pipeline. Unsupported on the GPU (supported = false):
// RGB-operator curves (AgX, PBR Neutral, the ICtCp mapper), curves applied to luminance
// (they can leave the display gamut, which the CPU maps back in ICtCp), grading LUTs and
// sRGB-space UI blending, which run on the CPU. What the program covers agrees with the
// CPU within one code.
EncodeProgram make_encode_program(const PreparedPipeline& p);

// Builds the frame from the integer target read back (rows bottom-up when
// `bottom_up`, as glReadPixels returns them): copies/reorders into the DRM buffer,
// fills signal16 when present, and measures MaxCLL/MaxFALL from the codes.
Result<EncodedFrame> frame_from_readback(const PreparedPipeline& p, const EncodeProgram& prog, int width,
                                         int height, const void* pixels, bool bottom_up);

}  // namespace hdrd::gpu

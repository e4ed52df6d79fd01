// The fused SIMD row kernel for the common encode path: half/float input -> sanitise ->
// input matrix with exposure -> tone (clip, ratio of max(RGB) or luminance, or per-channel
// LUT) -> container matrix -> signal LUT -> codes -> packed DRM pixels (+ PNG samples,
// MaxCLL/MaxFALL). Pixels that leave the display gamut are reported back for the exact
// (ICtCp) path. Dispatches at run time to the best SIMD target (Highway).
#pragma once

#include <cstddef>
#include <cstdint>

#include "encode/kernel/float_lut.hpp"

namespace hdrd::kernels {

struct LutView {
  const float* table = nullptr;  // FloatBitsLut::table()
  const float* pairs = nullptr;  // FloatBitsLut::pairs()
  std::uint32_t base_bits = 0;
  float lo = 0, hi = 0;
  float hi_prev = 0;  // the largest float below hi
  float flat_below = 0;  // FloatBitsLut::flat_below(): below it the lookup is table[0] exactly
  const FloatBitsLut::Patch* patches = nullptr;  // FloatBitsLut::patches(): its kinks
  int patch_count = 0;
};

// FloatBitsQuantizer (float_lut.hpp) for a vector.
struct QuantView {
  const std::uint32_t* table = nullptr;  // FloatBitsQuantizer::table(), or null: codes from `signal`
  std::uint32_t base_bits = 0, top_rel = 0;
  int shift = 16;
};

enum class FusedTone : int { clip = 0, ratio_max = 1, ratio_luminance = 2, per_channel = 3 };
enum class FusedOut : int { packed10 = 0, xrgb8 = 1, scrgb = 2 };

struct FusedRow {
  // input (one of the two), n pixels
  const std::uint16_t* half_in = nullptr;
  const float* float_in = nullptr;
  int n = 0;
  const float* m_in = nullptr;  // 3x3 row-major, exposure folded in
  FusedTone tone = FusedTone::clip;
  float paper_white = 203, peak = 1000;
  LutView tone_lut;                    // per_channel: the curve's table with a toe (ToneStage)
  float tone_zero = 0, tone_toe_slope = 0;
  LutView lift;                        // ratio: per-channel black lift (table null: none)
  float lift_zero = 0, lift_toe_slope = 0;
  const float* m_container = nullptr;  // null: container = working (Rec.2020)
  float gamut_lo = 0, gamut_hi = 0;    // accepted container range (tolerances included)
  bool gamut_check = true;             // false: the tone keeps every pixel in [0, peak]
  // UI blended in linear container light after the gamut check (not for scRGB): n x
  // (premultiplied nits r, g, b, fraction of the frame kept), or null. Where ui_max passes
  // the peak the blend is clipped to it (the displayable volume).
  const float* ui = nullptr;
  float ui_max = 0;  // the largest r, g or b in ui
  FusedOut out_kind = FusedOut::packed10;
  LutView signal;                      // nits -> E' (PNG samples; codes when `codes` is null)
  QuantView codes;                     // nits -> code, exact
  float code_scale = 1023, code_offset = 0;
  int max_code = 1023;                 // SignalStage::peak_code: no code above the peak
  float signal_max = 1.0f;             // SignalStage::signal_max (16-bit PNG samples)
  bool narrow = false;
  std::uint8_t* out = nullptr;         // row start
  std::uint16_t* signal16 = nullptr;   // row start or null
  const float* code_to_nits = nullptr; // MaxCLL from decoded codes (hdr10), or null
  // MaxFALL: code_to_nits as a quartic in code % 32 per 32 codes, 5 x 32 floats
  // (coefficient i of segment s at [32 i + s]), or null (then the table itself).
  const float* code_nits_poly = nullptr;
  // The display light of the row (the EXR dump's EncodedFrame::display_nits), or null:
  // RGBA floats from the row start, RGB written and A set to 1. Container nits clamped to
  // [display_lo, display_hi] (the displayable volume with its black floor), except scRGB,
  // whose light is written as it is (negatives allowed).
  float* display = nullptr;
  float display_lo = 0, display_hi = 0;
  // results
  double max_nits = 0, sum_nits = 0;   // CLL of the pixels handled here
  int* fallback = nullptr;             // capacity n: x of pixels left for the exact path
  int fallback_count = 0;
  int done = 0;                        // pixels [0, done) handled (the rest: a tail for the scalar path)
};

void fused_row(FusedRow& r);

}  // namespace hdrd::kernels

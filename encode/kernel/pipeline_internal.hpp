// Internal pieces of the encode pipeline shared by pipeline.cpp, the fast kernels and the
// GPU program generator: stage tables built from the reference functions.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "encode/colour/transfer.hpp"
#include "encode/kernel/constants.hpp"
#include "encode/kernel/float_lut.hpp"
#include "encode/pipeline.hpp"

namespace hdrd::detail {

// How the tone stage runs in the fast path.
enum class ToneKind {
  clip,         // exact: min(x * paper_white, peak) per channel
  per_channel,  // value LUT per channel
  ratio,        // ratio LUT of max(RGB) or luminance, applied to all channels
  reference,    // per-pixel reference (RGB operators such as AgX, the ICtCp mapper)
  none,         // a baked grade holds the tone curve
};

struct ToneStage {
  ToneKind kind = ToneKind::reference;
  bool ratio_of_luminance = false;  // ratio: luminance instead of max(RGB)
  // per_channel: nits = f(x) from the table, and below its bottom (2^-20) the straight line
  // from f(0) = zero_nits with slope toe_slope to the bottom value (toe_lookup): black is
  // the curve's black exactly (the table's bottom value f(2^-20) made black PQ code 1 with
  // hable) and light below the table keeps the curve's average slope there.
  // ratio: nits = channel x lut(k), lut = shape(k) / k in nits.
  FloatBitsLut lut;
  float zero_nits = 0, toe_slope = 0;
  // The curve's per-channel black lift after a ratio (tonemap::Curve::lifts_black, BT.2390
  // §5.4 step E3), on nits, with the same toe; has_lift false when it has none.
  bool has_lift = false;
  FloatBitsLut lift;
  float lift_zero_nits = 0, lift_toe_slope = 0;
  float paper_white = 203, peak = 1000;
};

// ToneStage's lookup with a toe: f(0) + x slope below the table's bottom, the table above.
inline float toe_lookup(const FloatBitsLut& lut, float zero, float slope, float x) {
  return x < lut.lo() ? zero + std::max(x, 0.0f) * slope : lut(x);
}

// Encoding of container-primaries display nits into the mode's signal.
struct SignalStage {
  Mode mode = Mode::hdr10;
  FloatBitsLut signal;              // nits -> E' (pq, srgb, gamma 2.2, BT.1886); HLG: E -> E' (with beta)
  FloatBitsQuantizer codes;         // nits -> code, exact (not HLG, whose signal is not of nits alone)
  float code_scale = 1023, code_offset = 0;  // code = E' * scale + offset (before rounding)
  int max_code = 1023;
  // No code decodes above the display peak (ST 2086: the content's light stays within the
  // mastering display's maximum): the largest code whose decoded light is at most the peak,
  // where every path clamps (rounding to the nearest code put half of all integer PQ peaks
  // a code above: 150 cd/m2 gave code 577 = 150.9 cd/m2). max_code for transfers whose top
  // signal is the peak (SDR, HLG). signal_max: the same for the 16-bit full-range PNG
  // samples, round(E' 65535) <= the largest sample at or below the peak.
  int peak_code = 1023;
  float signal_max = 1.0f;
  float hlg_peak = 1000, hlg_gamma = 1.2f;
  transfer::HlgDisplay hlg;         // hlg: the display model the codes are for
  std::vector<float> code_to_nits;  // for MaxCLL/MaxFALL: decoded display light per code (hlg: scene light)
  // HDR10 at 10 bits: code_to_nits as a least-squares quartic per 32 codes in
  // t = code % 32, coefficient i of segment s at [32 i + s] (the SIMD MaxFALL sum), and
  // its largest error over all codes, evaluated in float as the kernel does; empty when
  // that error is above kCodeLightFitTolerance.
  std::vector<float> code_nits_poly;
  double code_nits_poly_error = 0;
};
// The largest error of code_nits_poly kept (nits): MaxFALL is reported in whole nits.
inline constexpr double kCodeLightFitTolerance = 1e-3;

// HLG display light of a pixel from its scene light e = inverse OETF (code_to_nits):
// F_D = gain * e with gain = Lw * Ys^(gamma - 1), Ys the Rec.2020 luminance of e
// (BT.2100 table 5, Lb = 0). Shared by the encoder's MaxCLL and measure_frame_light.
inline float hlg_ootf_gain(const SignalStage& s, float er, float eg, float eb) {
  const float ys = kernel::rec2020_luminance(er, eg, eb);
  return ys > 0 ? s.hlg_peak * std::pow(ys, s.hlg_gamma - 1) : 0.0f;
}

// The largest code (at the target's depth and range) and the largest 16-bit full-range PNG
// sample whose light is at most the peak (SignalStage::peak_code, signal_max): ST 2084
// decoded per code; for SDR and HLG, whose top signal is the peak, the top code.
struct PeakCodes {
  int code = 1023;
  int signal16 = 65535;
};
PeakCodes peak_codes(const DisplayTarget& t);

ToneStage build_tone_stage(const PreparedPipeline& p);
SignalStage build_signal_stage(const DisplayTarget& t);
// The same, from a small process-wide cache: the tables depend only on the curve, its
// parameters and the display (exposure is folded into the input matrix), so a sequence
// or a daemon re-preparing every frame builds them once.
std::shared_ptr<const ToneStage> cached_tone_stage(const PreparedPipeline& p);
std::shared_ptr<const SignalStage> cached_signal_stage(const DisplayTarget& t);

// Reference helpers (double precision).
color::Vec3 sanitize(color::Vec3 v);
color::Mat3 working_to_container(const DisplayTarget& t);
// The container range accepted without gamut mapping: [-tol, peak (1 + tol)] with a
// tolerance for float rounding of in-gamut colours (values inside are clamped).
inline constexpr double kGamutTolerance = 1e-4;
inline float gamut_low(const DisplayTarget& t) { return static_cast<float>(-kGamutTolerance * t.peak_nits); }
inline float gamut_high(const DisplayTarget& t) { return static_cast<float>(t.peak_nits * (1 + kGamutTolerance)); }

// The displayable volume of a mode: the container light its codes can make a display
// emit. hdr10 and SDR: the [0, peak] cube in the container; hlg: the image of the
// [0, 1]^3 scene-light cube under the display's OOTF, which for saturated colours ends
// below the peak (a Rec.2020 blue reaches 569 of 1000 cd/m2); scrgb: everything.
bool in_volume(color::Vec3 container_nits, const DisplayTarget& t, double tolerance);
// Working-space light (after tone mapping) -> container light inside the volume: what does
// not fit is desaturated at constant ICtCp intensity toward the achromatic axis (REFERENCE.md
// §1.5), or clipped with GamutMapping::clip; HLG colours then go through fit_volume.
color::Vec3 gamut_map(color::Vec3 working_nits, const DisplayTarget& t, GamutMapping g,
                      const gamut::Mapper* mapper = nullptr);
// The prepared map of the family (gamut_map.hpp) from the input's gamut into the container
// (cached: its tables take ~0.2 s), null for ictcp, clip and scrgb.
std::shared_ptr<const gamut::Mapper> cached_gamut_mapper(GamutMapping g, const color::Mat3& input_to_working,
                                                         const DisplayTarget& t, bool to_display = false);
// The display's own gamut when it is known and lies inside the container (gamut_target display).
std::optional<color::Primaries> display_gamut(const DisplayTarget& t);
// A map that moves colours inside the container too (perceptual, saturation, linear, darken
// from a source wider than the container): every pixel goes through it, none through the
// fused kernel or the GPU program.
bool maps_every_pixel(const PreparedPipeline& p);
// Container light -> inside the volume, for light that is in the container's cube already
// (or nearly: the UI composite): the cube clamp, and for hlg the largest scene-light scale
// that fits, at constant luminance (ictcp) or the per-channel clip of E (clip).
color::Vec3 fit_volume(color::Vec3 container_nits, const DisplayTarget& t, GamutMapping g);
// What the display emits for container light inside the volume: the black floors of the
// EOTFs with a black level (BT.1886: Lb per channel; HLG with Lb > 0: the lifted black
// OETF^-1(beta) per channel in scene light). The codes are the same either way; the dump
// is what a display decoding them shows.
color::Vec3 displayed_light(color::Vec3 container_nits, const DisplayTarget& t);
bool has_black_floor(const DisplayTarget& t);

// Converts float <-> IEEE half (round to nearest even).
using ::hdrd::float_to_half;  // encode/image.hpp
using ::hdrd::half_to_float;

}  // namespace hdrd::detail

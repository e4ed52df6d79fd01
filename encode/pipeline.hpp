// The encode pipeline (REFERENCE.md §1): scene light -> exposure -> relative scene value
// -> [scene grade] -> tone curve -> display luminance (cd/m2) -> [display grade] ->
// gamut mapping -> UI composite -> encoding -> DRM buffer + metadata.
//
// encode_frame() is the one entry point. It runs a fast path (baked LUTs, SIMD, threads)
// whose tables are evaluated from the scalar reference functions in this module, and a
// reference path (reference_encode_pixel) that tests use as the oracle.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "encode/colour/color.hpp"
#include "encode/colour/gamut_map.hpp"  // GamutMapping (REFERENCE.md §1.5)
#include "encode/display_target.hpp"
#include "encode/tone/exposure.hpp"
#include "encode/frame.hpp"
#include "encode/grade/grade.hpp"
#include "encode/image.hpp"
#include "encode/result.hpp"
#include "encode/tone/tonemap.hpp"

namespace hdrd {

enum class InputUnits { relative, absolute };
std::string_view to_string(InputUnits u);
std::optional<InputUnits> parse_input_units(std::string_view s);


struct ToneSettings {
  std::string curve;                       // empty: the mode's default (tonemap::default_curve)
  tonemap::ParamValues params;
  std::optional<tonemap::Apply> apply;     // empty: the curve's default
  // HDR outputs: the frame average of maxRGB (cd/m2, what MaxFALL measures) is held at or
  // below this by lowering the exposure (a display's ABL budget); never with `clip`.
  std::optional<double> max_frame_average_nits;
};

// What apply_frame_average_limit decided (the sidecar's exposure.frame_average_limit).
struct FrameAverageLimit {
  double limit_nits = 0;
  double predicted_nits = 0;        // the frame average before the limit, from the samples
  double limited_nits = 0;          // after it (= predicted when not applied)
  double exposure_factor = 1;       // the exposure scale was multiplied by this (<= 1)
  bool applied = false;
  std::string not_applied;          // why not, when it is not (clip curve, SDR output)
};

struct UiSettings {
  std::shared_ptr<const OverlayImage> overlay;  // null: no UI
  int x = 0, y = 0;                        // top-left position in output pixels
  double scale = 1.0;                      // overlay pixel size in output pixels (bilinear)
  bool srgb_blend = false;                 // blend in sRGB-encoded space (UIs authored that way)
  double dim = 0.0;                        // darken the frame under the UI by dim * alpha
};

struct EncodeSettings {
  DisplayTarget target = default_target(Mode::hdr10);
  exposure::Settings exposure;
  ToneSettings tone;
  GamutMapping gamut = GamutMapping::ictcp;
  // Map into the display's own primaries (target.display_primaries, from its EDID) where
  // they lie inside the container, instead of the container's.
  bool gamut_to_display = false;
  UiSettings ui;
  std::shared_ptr<const grade::Grade> grade;
  bool dither = false;                     // ordered dither on code values (off in tests)
  bool keep_display_nits = false;          // fill EncodedFrame::display_nits (EXR dumps)
  bool staged_only = false;                // every pixel on the staged path, not the fused kernel (tests)
  bool png_samples = true;                 // fill EncodedFrame::signal16 (16-bit PNG samples)
  int threads = 0;                         // 0: all hardware threads
};

// What the pipeline reads: linear light with a declared meaning.
struct SceneInput {
  const Image* image = nullptr;            // float RGBA, or
  const ImageHalf* half = nullptr;         // half RGBA (GPU readback)
  color::Mat3 to_working = color::to_working(color::Space::rec709);
  InputUnits units = InputUnits::relative;
  double white_luminance_nits = 1.0;       // absolute input: value * this = cd/m2
  std::optional<double> illuminance_lux;   // dominant illuminance (light-based exposure)
};

// Everything resolved for one frame: the prepared curve, the metered exposure, the
// matrices. Built once per request; shared by the CPU fast path and the GPU program.
struct PreparedPipeline {
  EncodeSettings settings;
  std::shared_ptr<const tonemap::Curve> curve;
  const tonemap::ToneCurveInfo* curve_info = nullptr;
  tonemap::Apply apply = tonemap::Apply::max_rgb;
  tonemap::ParamValues params;             // resolved
  exposure::Metering metering;
  color::Mat3 input_to_working;            // includes nothing but primaries
  double scene_scale = 1.0;                // input value -> relative (exposure, units, compensation)
  double unit_nits = 1.0;                  // cd/m2 of input value 1.0 (absolute: white luminance; relative: paper white)
  // The metered samples (scene_luminance_nits) when the exposure mode read the image;
  // a sequence's temporal decisions reuse them.
  std::shared_ptr<const std::vector<float>> luminance_nits;
  // The gamut map from the input's gamut into the container's, for every map but ictcp
  // and clip (which need no tables); null for those and for scrgb.
  std::shared_ptr<const gamut::Mapper> gamut_mapper;
  std::optional<FrameAverageLimit> frame_average_limit;  // when tone.max_frame_average_nits is set
  nlohmann::json describe() const;         // settings for the sidecar
};

// Validates settings and meters exposure on the input (auto modes read the image).
Result<PreparedPipeline> prepare_pipeline(const SceneInput& input, const EncodeSettings& settings);

// Scene luminance in cd/m2 of (a subsample of, at most ~2 Mpx) the input: what the
// auto-exposure modes meter and a sequence's temporal decisions read (encode/tone/temporal.hpp).
std::vector<float> scene_luminance_nits(const SceneInput& input, double unit_nits, std::size_t max_samples = 1u << 21);

// A sequence's decisions for one frame, applied to its prepared pipeline: the exposure
// scale (cd/m2 -> relative, what exposure::meter returns; the sidecar's exposure.scale) and
// a source peak for curves that take one (relative, 1.0 = diffuse white). The curve's
// source-peak parameter (bt2390 source_peak_nits, lottes-hdr hdr_max, drago scene_max) is
// set, clamped to its range, and the curve prepared again; curves without one are unchanged.
// average_relative, when given, sets the scene average of curves that place a knee on it
// (source_avg_nits: spline, st2094-40, st2094-10) the same way.
void set_exposure_scale(PreparedPipeline& p, double scale);
Result<void> set_source_peak(PreparedPipeline& p, std::optional<double> peak_relative,
                             std::optional<double> average_relative = {});
// The scene-average parameter of curves that take one ("source_avg_nits"), or empty.
std::string_view source_average_param(const tonemap::ToneCurveInfo& curve);
// tone.max_frame_average_nits: predicts the frame average of maxRGB in the display light
// (the reference path on a subsample of at most kFrameAverageSamples input pixels) and,
// when it is above the limit, lowers the exposure scale until it is not (bisection in
// stops). Call it after the exposure is final (a sequence's decision included). Not
// applied with the `clip` curve (its levels are exact: x * paper white) or to SDR
// outputs; no-op without the setting. The UI overlay is not part of the prediction.
inline constexpr std::size_t kFrameAverageSamples = 1u << 14;
void apply_frame_average_limit(PreparedPipeline& p, const SceneInput& input);
// The name of the curve's source-peak parameter, empty when it has none.
std::string_view source_peak_param(const tonemap::ToneCurveInfo& curve);

// Reference path for one pixel: input RGB (as stored) -> display nits in the container
// primaries after tone mapping, grading and gamut mapping (no UI). Double precision.
color::Vec3 reference_display_nits(const PreparedPipeline& p, color::Vec3 input_rgb);
// Display nits (container primaries) -> signal E' per channel for the mode (scrgb: value/80).
color::Vec3 reference_signal(const DisplayTarget& t, color::Vec3 container_nits);

// The whole frame.
Result<EncodedFrame> encode_frame(const SceneInput& input, const EncodeSettings& settings);
Result<EncodedFrame> encode_prepared(const SceneInput& input, const PreparedPipeline& prepared);
// Same, encoding into `frame` and reusing its buffers when the size matches (a real-time
// loop keeps its scan-out buffers instead of allocating and zeroing them every frame).
Result<void> encode_prepared_into(const SceneInput& input, const PreparedPipeline& prepared, EncodedFrame& frame);

}  // namespace hdrd

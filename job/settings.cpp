#include "job/settings.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "encode/colour/gamut_map.hpp"
#include "encode/display_target.hpp"
#include "job/outputs.hpp"

namespace hdrd::job {
namespace {

using nlohmann::json;

constexpr std::string_view kRanges[] = {"full", "narrow"};
constexpr std::string_view kSdrCurves[] = {"srgb", "gamma22"};
constexpr std::string_view kSdrEotfs[] = {"srgb", "gamma22", "bt1886"};
constexpr std::string_view kInverseTonemaps[] = {"linear", "bt2446c", "bt2446a-inverse"};
constexpr std::string_view kApply[] = {"per-channel", "max-rgb", "luminance", "rgb"};
constexpr const auto& kGamut = kGamutMappingNames;
constexpr std::string_view kGamutTargets[] = {"container", "display"};
constexpr std::string_view kExposureModes[] = {"auto", "manual", "camera", "log-average", "histogram", "light"};
constexpr std::string_view kBlend[] = {"linear", "srgb"};
constexpr std::string_view kPlacement[] = {"scene", "display", "baked"};
constexpr std::string_view kEncoder[] = {"auto", "gpu", "cpu"};
constexpr std::string_view kInputUnits[] = {"relative", "absolute"};
constexpr std::string_view kAvifMatrix[] = {"rgb", "ycbcr"};
constexpr std::string_view kChroma[] = {"444", "422", "420"};
constexpr std::string_view kGainMapChannels[] = {"rgb", "luminance"};
constexpr std::string_view kCodecs[] = {"hevc", "av1", "h264"};
constexpr std::string_view kContainers[] = {"mp4", "mkv"};
constexpr std::string_view kAv1Encoders[] = {"libsvtav1", "libaom-av1"};
constexpr std::string_view kSdrVideoTransfers[] = {"bt709", "srgb"};
constexpr std::string_view kGranularity[] = {"scene", "frame"};
constexpr std::string_view kPacing[] = {"every-frame", "realtime"};
constexpr std::string_view kBackends[] = {"auto", "egl", "egl-device", "egl-surfaceless", "osmesa"};

// The table. Order is the order of --help, docs/settings.md and capabilities.
std::vector<Setting> make_table() {
  using T = Type;
  const auto modes = mode_names();
  return {
      // ---- the display (REFERENCE.md §1.4, §1.8, §1.9) ----
      {.path = "display.mode", .type = T::choice, .sources = kAllSources,
       .doc = "Output mode", .choices = modes,
       .default_doc = "the display's (display.connector / display.edid), else hdr10",
       .flag = "--mode", .metavar = "MODE", .query = "mode", .header = "X-Hdrd-Mode"},
      {.path = "display.peak_nits", .type = T::number, .sources = kAllSources,
       .doc = "Display peak luminance", .unit = "cd/m2", .min = 1e-3, .max = 10000,
       .default_doc = "the display's, else the mode's: hdr10/hlg/scrgb 1000, sdr 100",
       .flag = "--peak", .metavar = "NITS", .query = "peak_nits", .header = "X-Hdrd-Peak-Nits"},
      {.path = "display.black_nits", .type = T::number, .sources = kAllSources,
       .doc = "Display black luminance", .unit = "cd/m2", .min = 0, .max = 10000,
       .default_doc = "the display's, else the mode's: hdr10 0.005, sdr 0.1, hlg/scrgb 0",
       .flag = "--black", .metavar = "NITS", .query = "black_nits", .header = "X-Hdrd-Black-Nits"},
      {.path = "display.paper_white_nits", .type = T::number, .sources = kAllSources,
       .doc = "Luminance of relative 1.0 (diffuse white)", .unit = "cd/m2", .min = 1e-3, .max = 10000,
       .default_doc = "HDR modes 203 (BT.2408), SDR modes = the peak",
       .flag = "--paper-white", .metavar = "NITS", .query = "paper_white_nits", .header = "X-Hdrd-Paper-White-Nits"},
      {.path = "display.ui_white_nits", .type = T::number, .sources = kAllSources,
       .doc = "Luminance of UI white", .unit = "cd/m2", .min = 1e-3, .max = 10000,
       .default_doc = "= paper white", .flag = "--ui-white", .metavar = "NITS", .query = "ui_white_nits"},
      {.path = "display.sdr_white_nits", .type = T::number, .sources = kAllSources,
       .doc = "Where SDR content's white lands in an HDR frame", .unit = "cd/m2", .min = 1e-3, .max = 10000,
       .default_doc = "= paper white", .flag = "--sdr-white", .metavar = "NITS", .query = "sdr_white_nits"},
      {.path = "display.range", .type = T::choice, .sources = kAllSources,
       .doc = "Code range (KMS scan-out is always full)", .choices = kRanges,
       .default_doc = "full (bt2111 bars: narrow, as the standard defines them)",
       .flag = "--range", .metavar = "RANGE", .query = "range", .header = "X-Hdrd-Range"},
      {.path = "display.bits", .type = T::integer, .sources = kAllSources,
       .doc = "Bits per channel: 10 (hdr10, hlg), 8 or 10 (sdr), 16 (scrgb)", .min = 8, .max = 16,
       .default_doc = "the mode's: 10, SDR 8, scRGB 16", .flag = "--bits", .metavar = "N", .query = "bits",
       .header = "X-Hdrd-Bits"},
      {.path = "display.sdr_curve", .type = T::choice, .sources = kAllSources,
       .doc = "SDR transfer: srgb (piecewise) or gamma22", .choices = kSdrCurves, .default_json = "\"srgb\"",
       .flag = "--sdr-curve", .metavar = "CURVE", .query = "sdr_curve"},
      {.path = "display.sdr_content_eotf", .type = T::choice, .sources = kAllSources,
       .doc = "EOTF SDR content (the UI overlay, SDR input, sdr-grey/sdr-shadows) was mastered with; decides its "
              "shadows in HDR frames",
       .choices = kSdrEotfs, .default_json = "\"srgb\"", .flag = "--sdr-eotf", .metavar = "EOTF",
       .query = "sdr_content_eotf"},
      {.path = "display.connector", .type = T::text, .sources = kAllSources,
       .doc = "Take mode, levels and primaries from an attached display: 'auto' (the first HDR-capable one) "
              "or a connector name",
       .default_doc = "none", .flag = "--display", .metavar = "auto|NAME", .query = "display", .max_length = 64},
      {.path = "display.edid", .type = T::path, .sources = kAllSources,
       .doc = "Take mode, levels and primaries from an EDID file", .default_doc = "none", .flag = "--edid",
       .metavar = "FILE", .query = "edid", .max_length = 4096},
      {.path = "display.profile", .type = T::path, .sources = kAllSources,
       .doc = "Display profile override file (TOML or JSON; docs/displays.md)", .default_doc = "none",
       .flag = "--profile", .metavar = "FILE", .query = "profile", .max_length = 4096},

      // ---- tone mapping (REFERENCE.md §1.3, §1.5) ----
      {.path = "tone.curve", .type = T::text, .sources = kSceneReferred,
       .doc = "Tone curve (hdrd tonemap --list; GET /v1/capabilities tone_curves)", .default_json = "\"pq-shoulder\"",
       .flag = "--tonemap", .metavar = "CURVE", .query = "curve", .header = "X-Hdrd-Tone-Curve", .max_length = 64},
      {.path = "tone.params", .type = T::number_map, .sources = kSceneReferred,
       .doc = "Curve parameters by name (ranges: hdrd tonemap --list)", .min = -1e9, .max = 1e9,
       .default_doc = "each parameter's default", .flag = "--tonemap-param", .metavar = "NAME=VALUE"},
      {.path = "tone.apply", .type = T::choice, .sources = kSceneReferred,
       .doc = "How the curve applies to RGB: per-channel, max-rgb or luminance (a scalar curve), or rgb (the curve's "
              "own RGB operator, the only way an RGB operator such as agx applies)",
       .choices = kApply,
       .default_doc = "the curve's", .flag = "--tonemap-apply", .metavar = "HOW", .query = "apply"},
      {.path = "tone.max_frame_average_nits", .type = T::number, .sources = kSceneReferred,
       .doc = "HDR outputs: hold the frame average of maxRGB at or below this by lowering the exposure (a display's "
              "ABL budget, e.g. 400); not applied with the clip curve or to SDR outputs",
       .unit = "cd/m2", .min = 1, .max = 10000, .default_doc = "none (off)", .flag = "--max-frame-average",
       .metavar = "NITS", .query = "max_frame_average_nits"},
      {.path = "gamut", .type = T::choice, .sources = kSceneReferred,
       .doc = "Gamut mapping after tone mapping, from the input's gamut into the output's: ictcp (constant "
              "intensity and hue, chroma reduced to the boundary; desaturate is the same), clip (per channel), "
              "perceptual (soft knee toward the boundary), relative (hue-preserving clip toward the cusp), "
              "absolute (relative without white adaptation), saturation, linear, darken, highlight (marks what "
              "is outside): docs/encoding.md",
       .choices = kGamut,
       .default_json = "\"ictcp\"", .flag = "--gamut", .metavar = "HOW", .query = "gamut"},
      {.path = "gamut_target", .type = T::choice, .sources = kSceneReferred,
       .doc = "The gamut mapped into: container (the signal's primaries) or display (the display's own primaries "
              "from its EDID or profile, when they lie inside the container; else the container)",
       .choices = kGamutTargets, .default_json = "\"container\"", .flag = "--gamut-target", .metavar = "WHERE",
       .query = "gamut_target"},

      // ---- exposure (REFERENCE.md §1.2, RTR4 §8.2.2) ----
      {.path = "exposure.mode", .type = T::choice, .sources = kSceneReferred,
       .doc = "Exposure: auto = camera when ev100 is given, light-based when illuminance_lux is given, histogram "
              "(Unreal's window average) for renders, manual for EXR input",
       .choices = kExposureModes, .default_json = "\"auto\"", .flag = "--exposure-mode", .metavar = "MODE",
       .query = "exposure"},
      {.path = "exposure.compensation_ev", .type = T::number, .sources = kSceneReferred,
       .doc = "Compensation in stops, applied last in every mode (+ brightens)", .unit = "stops", .min = -30,
       .max = 30, .default_json = "0", .flag = "--exposure", .metavar = "EV", .query = "exposure_comp_ev",
       .alias = "exposure_comp_ev"},
      {.path = "exposure.gain", .type = T::number, .sources = kSceneReferred, .doc = "Manual mode: extra linear gain",
       .min = 1e-9, .max = 1e9, .default_json = "1", .flag = "--gain", .metavar = "K", .query = "gain"},
      {.path = "exposure.ev100", .type = T::number, .sources = kSceneReferred,
       .doc = "Camera exposure value at ISO 100 (implies the camera mode)", .unit = "EV", .min = -30, .max = 40,
       .default_doc = "from aperture, shutter and ISO", .flag = "--ev100", .metavar = "EV", .query = "ev100"},
      {.path = "exposure.aperture_f", .type = T::number, .sources = kSceneReferred, .doc = "Camera f-number",
       .min = 0.5, .max = 128, .default_json = "16", .flag = "--aperture", .metavar = "N", .query = "aperture",
       .alias = "exposure.aperture"},
      {.path = "exposure.shutter_s", .type = T::number, .sources = kSceneReferred, .doc = "Camera shutter time",
       .unit = "s", .min = 1e-6, .max = 3600, .default_json = "0.008", .flag = "--shutter", .metavar = "S",
       .query = "shutter", .alias = "exposure.shutter"},
      {.path = "exposure.iso", .type = T::number, .sources = kSceneReferred, .doc = "Camera ISO", .min = 1, .max = 1e7,
       .default_json = "100", .flag = "--iso", .metavar = "ISO", .query = "iso"},
      {.path = "exposure.percentile", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram mode: read this percentile of the window instead of its average in stops (50: Valve's "
              "median)",
       .unit = "%", .min = 0, .max = 100, .default_doc = "none: the window's average", .flag = "--percentile",
       .metavar = "P", .query = "percentile"},
      {.path = "exposure.percentile_target", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram mode: the relative value the window's average (or percentile) maps to", .min = 1e-6,
       .max = 1e4,
       .default_json = "0.18", .flag = "--percentile-target", .metavar = "V", .query = "percentile_target"},
      {.path = "exposure.ignore_dark_fraction", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram mode: fraction of the darkest pixels ignored (Unreal's low percent 80)", .min = 0,
       .max = 0.99, .default_json = "0.8",
       .flag = "--ignore-dark", .metavar = "F", .query = "ignore_dark_fraction"},
      {.path = "exposure.ignore_bright_fraction", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram mode: fraction of the brightest pixels ignored (Unreal's high percent 98.3)", .min = 0,
       .max = 0.99, .default_json = "0.017", .flag = "--ignore-bright", .metavar = "F", .query = "ignore_bright_fraction"},
      {.path = "exposure.min_ev100", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram and log-average modes: the darkest scene they expose for, as a camera EV100 (Unreal's min "
              "EV100; a black frame stays black)",
       .unit = "EV", .min = -30, .max = 40, .default_json = "-6", .flag = "--min-ev100", .metavar = "EV",
       .query = "min_ev100"},
      {.path = "exposure.max_ev100", .type = T::number, .sources = kSceneReferred,
       .doc = "Histogram and log-average modes: the brightest scene they expose for, as a camera EV100 (Unreal's "
              "max EV100)",
       .unit = "EV", .min = -30, .max = 40, .default_json = "20", .flag = "--max-ev100", .metavar = "EV",
       .query = "max_ev100"},
      {.path = "exposure.illuminance_lux", .type = T::number, .sources = kSceneReferred,
       .doc = "Light mode: the dominant illuminance", .unit = "lux", .min = 1e-6, .max = 1e7,
       .default_doc = "a render's dominant light", .flag = "--illuminance", .metavar = "LUX", .query = "illuminance_lux"},

      // ---- the time axis (sequences only: docs/sequences.md; RTR4 §8.2.2) ----
      {.path = "exposure.adaptation_time_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: time constant of exposure adaptation in stops, both directions unless one is given (0: "
              "every frame from its own metering; manual and camera exposure never adapt)",
       .unit = "s", .min = 0, .max = 1000, .default_doc = "per direction", .flag = "--adaptation", .metavar = "S",
       .sequence = true},
      {.path = "exposure.adaptation_brighten_time_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: adaptation time constant while the exposure rises (into the dark; Unreal's speed down 1)",
       .unit = "s", .min = 0, .max = 1000, .default_json = "1", .default_doc = "exposure.adaptation_time_s, else 1",
       .flag = "--adaptation-brighten", .metavar = "S", .sequence = true},
      {.path = "exposure.adaptation_darken_time_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: adaptation time constant while the exposure falls (into the light; Unreal's speed up 3)",
       .unit = "s", .min = 0, .max = 1000, .default_json = "0.333", .default_doc = "exposure.adaptation_time_s, else 0.333",
       .flag = "--adaptation-darken", .metavar = "S", .sequence = true},
      {.path = "tone.dynamic_peak", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Sequences: a curve that takes a source peak (bt2390's source_peak_nits) follows the frames' smoothed "
              "peak, and one that takes a scene average (source_avg_nits: spline, st2094-40, st2094-10) the smoothed "
              "mean luminance, unless tone.params sets them",
       .default_json = "true", .flag = "--no-dynamic-peak", .sequence = true},
      {.path = "tone.peak_percentile", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: the luminance percentile taken as a frame's peak", .unit = "%", .min = 50, .max = 100,
       .default_json = "99.99", .flag = "--peak-percentile", .metavar = "P", .sequence = true},
      {.path = "tone.peak_rise_time_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: time constant (stops) while the detected peak rises", .unit = "s", .min = 0, .max = 1000,
       .default_json = "0.25", .flag = "--peak-rise", .metavar = "S", .sequence = true},
      {.path = "tone.peak_fall_time_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: time constant (stops) while the detected peak falls", .unit = "s", .min = 0, .max = 1000,
       .default_json = "1", .flag = "--peak-fall", .metavar = "S", .sequence = true},
      {.path = "sequence.detect_cuts", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Sequences: detect scene cuts (a cut resets adaptation and the peak, starts a metadata scene and a "
              "keyframe)",
       .default_json = "true", .flag = "--no-detect-cuts", .sequence = true},
      {.path = "sequence.cut_threshold_stops", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: histogram distance between consecutive frames that makes a cut", .unit = "stops",
       .min = 0.05, .max = 30, .default_json = "2", .flag = "--cut-threshold", .metavar = "STOPS", .sequence = true},

      // ---- UI overlay (REFERENCE.md §1.6) ----
      {.path = "ui.path", .type = T::path, .sources = kSceneReferred,
       .doc = "UI overlay: an sRGB RGBA PNG composited at UI white", .default_doc = "none", .flag = "--ui",
       .metavar = "PNG", .query = "ui", .max_length = 4096},
      {.path = "ui.png_base64", .type = T::base64, .sources = kSceneReferred,
       .doc = "UI overlay PNG uploaded in the request body (base64)", .default_doc = "none",
       .reach = Reach::daemon},
      {.path = "ui.premultiplied", .type = T::boolean, .sources = kSceneReferred,
       .doc = "The overlay's alpha is premultiplied", .default_json = "false", .flag = "--ui-premultiplied",
       .query = "ui_premultiplied"},
      {.path = "ui.x", .type = T::integer, .sources = kSceneReferred, .doc = "Overlay left edge in output pixels",
       .unit = "px", .min = -16384, .max = 16384, .default_json = "0", .query = "ui_x"},
      {.path = "ui.y", .type = T::integer, .sources = kSceneReferred, .doc = "Overlay top edge in output pixels",
       .unit = "px", .min = -16384, .max = 16384, .default_json = "0", .query = "ui_y"},
      {.path = "ui.scale", .type = T::number, .sources = kSceneReferred,
       .doc = "Overlay pixel size in output pixels (bilinear)", .min = 1e-3, .max = 64, .default_json = "1",
       .flag = "--ui-scale", .metavar = "K", .query = "ui_scale"},
      {.path = "ui.blend", .type = T::choice, .sources = kSceneReferred,
       .doc = "Blend in linear light, or in sRGB for UIs authored that way", .choices = kBlend,
       .default_json = "\"linear\"", .flag = "--ui-blend", .metavar = "HOW", .query = "ui_blend"},
      {.path = "ui.dim", .type = T::number, .sources = kSceneReferred,
       .doc = "Dim the frame under translucent UI by this fraction of alpha", .min = 0, .max = 1, .default_json = "0",
       .flag = "--ui-dim", .metavar = "F", .query = "ui_dim"},
      {.path = "ui.inverse_tonemap", .type = T::choice, .sources = kAllSources,
       .doc = "How SDR content (the UI overlay, SDR input, sdr-* patterns) lands in HDR frames: linear (a gain to its "
              "white) or bt2446c (BT.2446-1 method C inverse; bt2446a-inverse is an alias), highlights expanded up "
              "to the peak at signal 1",
       .choices = kInverseTonemaps, .default_json = "\"linear\"", .flag = "--ui-inverse-tonemap", .metavar = "HOW",
       .query = "ui_inverse_tonemap"},

      // ---- grading (RTR4 §8.2.3; docs/grading.md) ----
      {.path = "grade.lut", .type = T::path, .sources = kSceneReferred,
       .doc = "3D LUT (.cube, or any format OpenColorIO reads)", .default_doc = "none", .flag = "--lut",
       .metavar = "FILE", .query = "lut", .max_length = 4096},
      {.path = "grade.shaper", .type = T::text, .sources = kSceneReferred,
       .doc = "Shaper of a scene-referred LUT: pq, log2, sqrt, sqrt-sqrt or none, optionally with its range "
              "(log2:-8:8, sqrt:16)",
       .default_doc = "the LUT file's, else pq", .flag = "--lut-shaper", .metavar = "SPEC", .query = "shaper",
       .max_length = 64},
      {.path = "grade.placement", .type = T::choice, .sources = kSceneReferred,
       .doc = "Where the LUT applies: scene (before the tone curve), display (after) or baked (replaces it)",
       .choices = kPlacement, .default_json = "\"display\"", .flag = "--grade", .metavar = "WHERE",
       .query = "placement"},
      {.path = "grade.trilinear", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Trilinear instead of tetrahedral LUT interpolation", .default_json = "false", .flag = "--lut-trilinear",
       .query = "trilinear"},
      {.path = "grade.ocio_config", .type = T::path, .sources = kSceneReferred, .doc = "OpenColorIO config",
       .default_doc = "$OCIO", .flag = "--ocio-config", .metavar = "FILE", .query = "ocio_config", .max_length = 4096},
      {.path = "grade.ocio_look", .type = T::text, .sources = kSceneReferred, .doc = "OpenColorIO look to apply",
       .default_doc = "none", .flag = "--ocio-look", .metavar = "LOOK", .query = "ocio_look"},
      {.path = "grade.ocio_display", .type = T::text, .sources = kSceneReferred,
       .doc = "OpenColorIO display (with grade.ocio_view)", .default_doc = "none", .flag = "--ocio-display",
       .metavar = "DISPLAY", .query = "ocio_display"},
      {.path = "grade.ocio_view", .type = T::text, .sources = kSceneReferred,
       .doc = "OpenColorIO view (with grade.ocio_display)", .default_doc = "none", .flag = "--ocio-view",
       .metavar = "VIEW", .query = "ocio_view"},

      // ---- the source ----
      {.path = "scene", .type = T::scene, .sources = kRender,
       .doc = "A built-in scene (material-grid, fresnel, furnace, hdr, underwater), a .gltf/.glb/.json file, or an "
              "inline JSON scene (docs/scene-format.md)",
       .default_json = "\"material-grid\"", .flag = "--scene", .metavar = "NAME|FILE", .max_length = 4096},
      {.path = "width", .type = T::integer, .sources = kRender | kPattern, .doc = "Frame width", .unit = "px",
       .min = 1, .max = 16384, .default_json = "1920", .flag = "--width", .metavar = "PX", .query = "width",
       .size_limit = true},
      {.path = "height", .type = T::integer, .sources = kRender | kPattern, .doc = "Frame height", .unit = "px",
       .min = 1, .max = 16384, .default_json = "1080", .flag = "--height", .metavar = "PX", .query = "height",
       .size_limit = true},
      {.path = "samples", .type = T::integer, .sources = kRender, .doc = "MSAA samples, 1 = off (the renderer caps at 16)",
       .min = 1, .max = 64, .default_json = "4", .flag = "--samples", .metavar = "N", .query = "samples",
       .size_limit = true},
      // ---- light from the world (docs/rendering.md "Environment") ----
      {.path = "environment.file", .type = T::path, .sources = kRender,
       .doc = "Equirectangular environment map (.exr, .hdr) lighting the scene; replaces its environment and ambient",
       .default_doc = "the scene's", .flag = "--environment", .metavar = "FILE", .max_length = 4096},
      {.path = "environment.scale", .type = T::number, .sources = kRender,
       .doc = "Environment radiance multiplier: EXR value x whiteLuminance x scale = cd/m2 (no whiteLuminance, .hdr: "
              "value x scale)",
       .min = 0, .max = 1e9, .default_json = "1", .flag = "--environment-scale", .metavar = "K"},
      {.path = "environment.rotation_deg", .type = T::number, .sources = kRender,
       .doc = "Turns the environment about +y, in the sense of growing azimuth", .unit = "deg", .min = -3600,
       .max = 3600, .default_json = "0", .flag = "--environment-rotation", .metavar = "DEG"},
      {.path = "environment.sky.sun_elevation_deg", .type = T::number, .sources = kRender,
       .doc = "Preetham sky: sun elevation (any environment.sky field, or --sky, lights the scene by the sky)",
       .unit = "deg", .min = 0, .max = 90, .default_doc = "45 (with a sky)", .flag = "--sky-elevation",
       .metavar = "DEG"},
      {.path = "environment.sky.sun_azimuth_deg", .type = T::number, .sources = kRender,
       .doc = "Preetham sky: sun azimuth, from -z toward +x", .unit = "deg", .min = -360, .max = 360,
       .default_doc = "0 (with a sky)", .flag = "--sky-azimuth", .metavar = "DEG"},
      {.path = "environment.sky.turbidity", .type = T::number, .sources = kRender,
       .doc = "Preetham sky: turbidity, 2 very clear .. 10 very hazy", .min = 1.7, .max = 10,
       .default_doc = "2.5 (with a sky)", .flag = "--sky-turbidity", .metavar = "T"},
      {.path = "environment.sky.ground_albedo", .type = T::number, .sources = kRender,
       .doc = "Preetham sky: albedo of the ground below the horizon", .min = 0, .max = 1,
       .default_doc = "0.2 (with a sky)", .flag = "--sky-ground-albedo", .metavar = "A"},
      {.path = "environment.sky.sun", .type = T::boolean, .sources = kRender,
       .doc = "Preetham sky: the sun as a shadowing light and a disc (false: the sky dome only)",
       .default_json = "true", .flag = "--no-sky-sun"},
      {.path = "energy_compensation", .type = T::boolean, .sources = kRender,
       .doc = "GGX multiple-scattering energy compensation (false: single scattering, for comparison)",
       .default_json = "true", .flag = "--no-energy-compensation", .query = "energy_compensation"},
      // glTF gives emission no unit. 1.0 = 100/pi cd/m2: a white diffuser's luminance under the
      // default rig's 100 lux, which light-based exposure shows as paper white, so an emissive
      // 1.0 surface looks white as glTF viewers show it (docs/scene-format.md "glTF files").
      {.path = "gltf_emissive_nits", .type = T::number, .sources = kRender,
       .doc = "Luminance of a glTF emissive value of 1.0 (emissiveFactor x KHR_materials_emissive_strength x texture); "
              "the default, 100/pi, is a white diffuser's under the default rig's 100 lux (paper white)",
       .unit = "cd/m2", .min = 0, .max = 1e7, .default_json = "31.830988618379067", .flag = "--gltf-emissive-nits",
       .metavar = "NITS", .query = "gltf_emissive_nits"},
      {.path = "camera.position", .type = T::vec3, .sources = kRender, .doc = "Camera position (scene units, metres)",
       .max = 1e6, .default_doc = "the scene's", .flag = "--camera-position", .metavar = "X,Y,Z"},
      {.path = "camera.target", .type = T::vec3, .sources = kRender, .doc = "Point the camera looks at", .max = 1e6,
       .default_doc = "the scene's", .flag = "--camera-target", .metavar = "X,Y,Z"},
      {.path = "camera.fov_y_deg", .type = T::number, .sources = kRender, .doc = "Vertical field of view",
       .unit = "deg", .min = 1, .max = 179, .default_doc = "the scene's", .flag = "--fov", .metavar = "DEG",
       .query = "fov_y_deg"},
      {.path = "encoder", .type = T::choice, .sources = kRender,
       .doc = "Where a render is encoded: auto = the GPU pass on a hardware GPU when its program covers the request "
              "and no output needs the CPU's display light (EXR); the CPU otherwise, and on a software rasteriser "
              "(llvmpipe), where the CPU encoder is faster",
       .choices = kEncoder, .default_json = "\"auto\"", .flag = "--encoder", .metavar = "WHERE", .query = "encoder"},
      {.path = "input", .type = T::choice, .sources = kEncode, .doc = "How the EXR's values are meant (REFERENCE.md §1.1)",
       .choices = kInputUnits, .default_doc = "absolute when the file has whiteLuminance, else relative",
       .flag = "--input", .metavar = "UNITS", .query = "input"},
      {.path = "pattern", .type = T::text, .sources = kPattern,
       .doc = "Test pattern: bt2111, pq-ramp, window, near-black, clipping, sdr-grey (docs/patterns.md)",
       .default_doc = "required", .max_length = 64},
      {.path = "params.level_nits", .type = T::number, .sources = kPattern,
       .doc = "window: the level; clipping: the 1.0x square's level (squares 0.7..1.5x, encoded over the signal's "
              "full range, so the display, not hdrd, clips them)", .unit = "cd/m2", .min = 1e-4, .max = 10000,
       .default_doc = "the display's peak", .flag = "--level", .metavar = "NITS", .query = "level_nits"},
      {.path = "params.area_percent", .type = T::number, .sources = kPattern,
       .doc = "window: area in percent of the frame (1, 2, 10, 25, 50, 100 are the usual)", .unit = "%", .min = 0.01,
       .max = 100, .default_json = "10", .flag = "--area", .metavar = "PERCENT", .query = "area_percent"},
      {.path = "params.steps", .type = T::integer, .sources = kPattern,
       .doc = "pq-ramp, sdr-grey: number of steps; near-black: how many of its 10 levels", .min = 1, .max = 256,
       .default_doc = "pq-ramp/sdr-grey 11, near-black 10", .flag = "--steps", .metavar = "N", .query = "steps"},
      {.path = "params.labels", .type = T::boolean, .sources = kPattern, .doc = "Draw the cd/m2 (or %) labels",
       .default_json = "true", .flag = "--no-labels", .query = "labels"},

      // ---- outputs ----
      {.path = "formats", .type = T::choice_list, .sources = kAllSources,
       .doc = "Files of a dump: png, exr (display light), raw (DRM buffer), scene-exr (a render's scene light), "
              "heatmap, avif, jxl, jpeg (SDR), jpeg-gainmap (HDR: SDR JPEG + gain map)",
       .choices = output_names(), .default_doc = "png, exr, raw (scrgb: exr, raw); renders add scene-exr",
       .flag = "--format", .metavar = "LIST", .query = "formats"},
      // ---- shareable stills (docs/dump-format.md §8-10) ----
      {.path = "quality", .type = T::integer, .sources = kAllSources,
       .doc = "Quality of the lossy stills: avif, jxl, jpeg and the gain-map JPEG's primary image (0..100)",
       .min = 0, .max = 100, .default_doc = "avif 80, jxl 90, jpeg 90", .flag = "--quality", .metavar = "Q",
       .query = "quality"},
      {.path = "lossless", .type = T::boolean, .sources = kAllSources,
       .doc = "avif and jxl keep the frame's samples exactly", .default_json = "false", .flag = "--lossless",
       .query = "lossless"},
      {.path = "avif.bits", .type = T::integer, .sources = kAllSources, .doc = "AVIF bits per sample: 8, 10 or 12",
       .min = 8, .max = 12, .default_doc = "the frame's (10; 8 for 8-bit SDR)", .flag = "--avif-bits",
       .metavar = "BITS", .query = "avif_bits"},
      {.path = "avif.range", .type = T::choice, .sources = kAllSources, .doc = "AVIF sample range",
       .choices = kRanges, .default_doc = "the frame's", .flag = "--avif-range", .metavar = "RANGE",
       .query = "avif_range"},
      {.path = "avif.matrix", .type = T::choice, .sources = kAllSources,
       .doc = "AVIF planes: rgb (H.273 matrix 0) or the container's Y'CbCr", .choices = kAvifMatrix,
       .default_doc = "rgb when lossless, else ycbcr", .flag = "--avif-matrix", .metavar = "M", .query = "avif_matrix"},
      {.path = "avif.chroma", .type = T::choice, .sources = kAllSources, .doc = "AVIF chroma subsampling",
       .choices = kChroma, .default_doc = "444 when lossless or rgb, else 420", .flag = "--avif-chroma",
       .metavar = "SUB", .query = "avif_chroma"},
      {.path = "avif.speed", .type = T::integer, .sources = kAllSources,
       .doc = "libaom speed, 0 (slowest, smallest) .. 9 (fastest)", .min = 0, .max = 9,
       .default_doc = "9 when lossless, else 7", .flag = "--avif-speed", .metavar = "N", .query = "avif_speed"},
      {.path = "jxl.effort", .type = T::integer, .sources = kAllSources,
       .doc = "libjxl effort, 1 (fastest) .. 9", .min = 1, .max = 9, .default_json = "3", .flag = "--jxl-effort",
       .metavar = "N", .query = "jxl_effort"},
      {.path = "jpeg.chroma_444", .type = T::boolean, .sources = kAllSources,
       .doc = "JPEG without chroma subsampling (4:4:4 instead of 4:2:0)", .default_json = "false",
       .flag = "--jpeg-444", .query = "jpeg_444"},
      {.path = "gainmap.scale", .type = T::integer, .sources = kSceneReferred,
       .doc = "Gain map downscale: the map is ceil(width / scale) x ceil(height / scale)", .min = 1, .max = 16,
       .default_json = "1", .flag = "--gainmap-scale", .metavar = "N", .query = "gainmap_scale"},
      {.path = "gainmap.quality", .type = T::integer, .sources = kSceneReferred,
       .doc = "JPEG quality of the gain map image", .min = 1, .max = 100, .default_json = "85",
       .flag = "--gainmap-quality", .metavar = "Q", .query = "gainmap_quality"},
      {.path = "gainmap.channels", .type = T::choice, .sources = kSceneReferred,
       .doc = "One gain per channel (rgb: the HDR colour too) or one from luminance (smaller)",
       .choices = kGainMapChannels, .default_json = "\"rgb\"", .flag = "--gainmap-channels", .metavar = "C",
       .query = "gainmap_channels"},
      {.path = "gainmap.gamma", .type = T::number, .sources = kSceneReferred,
       .doc = "Gain map gamma (ISO 21496-1 gain_map_gamma, hdrgm:Gamma)", .min = 0.01, .max = 10,
       .default_json = "1", .flag = "--gainmap-gamma", .metavar = "G", .query = "gainmap_gamma"},
      {.path = "gainmap.offset_sdr", .type = T::number, .sources = kSceneReferred,
       .doc = "Offset added to the SDR light before the ratio (ISO 21496-1 base offset, hdrgm:OffsetSDR)", .min = 0,
       .max = 1, .default_json = "0.015625", .flag = "--gainmap-offset-sdr", .metavar = "K", .query = "gainmap_offset_sdr"},
      {.path = "gainmap.offset_hdr", .type = T::number, .sources = kSceneReferred,
       .doc = "Offset added to the HDR light before the ratio (ISO 21496-1 alternate offset, hdrgm:OffsetHDR)",
       .min = 0, .max = 1, .default_json = "0.015625", .flag = "--gainmap-offset-hdr", .metavar = "K",
       .query = "gainmap_offset_hdr"},
      // ---- sequences: frames, time, video (docs/sequences.md, docs/video.md) ----
      {.path = "frames", .type = T::integer, .sources = kSceneReferred,
       .doc = "Sequences: number of frames", .min = 1, .max = 1000000,
       .default_doc = "a render: the scene's animation (duration x fps + 1 frames), else 1; an encode: every input",
       .flag = "--frames", .metavar = "N", .size_limit = true, .sequence = true},
      {.path = "fps", .type = T::number, .sources = kSceneReferred, .doc = "Sequences: frame rate",
       .unit = "1/s", .min = 0.01, .max = 1000, .default_json = "24", .flag = "--fps", .metavar = "F",
       .sequence = true},
      {.path = "start_s", .type = T::number, .sources = kRender,
       .doc = "Scene time of the frame, or of a sequence's first frame (animated scenes: docs/scene-format.md)",
       .unit = "s", .min = -1e6, .max = 1e6, .default_json = "0", .flag = "--start-s", .metavar = "T"},
      {.path = "images", .type = T::path, .sources = kEncode,
       .doc = "Sequences: the EXR frames, a printf pattern (shot.%04d.exr), a directory of .exr files or a list "
              "file (one path per line); the CLI takes it as its input",
       .default_doc = "none", .max_length = 4096, .sequence = true},
      {.path = "video.codec", .type = T::choice, .sources = kSceneReferred,
       .doc = "Sequences: write OUTBASE.mp4 (or .mkv) with HEVC Main 10, AV1 10-bit or H.264 (SDR only)",
       .choices = kCodecs, .default_doc = "none (per-frame dumps only)", .flag = "--video", .metavar = "CODEC",
       .sequence = true},
      {.path = "video.container", .type = T::choice, .sources = kSceneReferred, .doc = "Sequences: video container",
       .choices = kContainers, .default_json = "\"mp4\"", .flag = "--container", .metavar = "C", .sequence = true},
      {.path = "video.crf", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: constant rate factor (lower: better, larger)", .min = 0, .max = 63,
       .default_doc = "hevc 22, av1 30, h264 20", .flag = "--crf", .metavar = "Q", .sequence = true},
      {.path = "video.preset", .type = T::text, .sources = kSceneReferred,
       .doc = "Sequences: encoder preset: x265/x264 ultrafast..placebo, SVT-AV1 0..13, libaom cpu-used 0..8",
       .default_doc = "x265/x264 medium, SVT-AV1 its own default (10), libaom 6", .flag = "--preset",
       .metavar = "P", .max_length = 16, .sequence = true},
      {.path = "video.lossless", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Sequences: lossless video (x265 lossless, libaom lossless, x264 qp 0): the Y'CbCr codes exactly",
       .default_json = "false", .flag = "--video-lossless", .sequence = true},
      {.path = "video.range", .type = T::choice, .sources = kSceneReferred, .doc = "Sequences: Y'CbCr code range",
       .choices = kRanges, .default_json = "\"narrow\"", .flag = "--video-range", .metavar = "RANGE",
       .sequence = true},
      {.path = "video.sdr_transfer", .type = T::choice, .sources = kSceneReferred,
       .doc = "Sequences: the transfer of SDR (--mode sdr) video: bt709 encodes for the BT.1886 display and tags "
              "H.273 transfer 1 (BT.709), as players and TVs expect of video (the frames are sdr-bt1886); srgb keeps "
              "the sRGB curve, tagged 13 (IEC 61966-2-1). An explicit --sdr-curve keeps its curve",
       .choices = kSdrVideoTransfers, .default_json = "\"bt709\"", .flag = "--sdr-video-transfer", .metavar = "T",
       .sequence = true},
      {.path = "video.keyframe_interval_s", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: longest closed GOP (every scene cut is a keyframe too)", .unit = "s", .min = 0.01,
       .max = 600, .default_json = "2", .flag = "--keyframe-interval", .metavar = "S", .sequence = true},
      {.path = "video.threads", .type = T::integer, .sources = kSceneReferred,
       .doc = "Sequences: encoder frame threads (fixed, so the bytes do not depend on the machine)", .min = 1,
       .max = 64, .default_json = "4", .flag = "--video-threads", .metavar = "N", .sequence = true},
      {.path = "video.av1_encoder", .type = T::choice, .sources = kSceneReferred, .doc = "Sequences: AV1 encoder",
       .choices = kAv1Encoders, .default_doc = "libsvtav1 (libaom-av1 when lossless)", .flag = "--av1-encoder",
       .metavar = "E", .sequence = true},
      {.path = "video.dynamic_metadata", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Sequences: embed HDR10+ (ST 2094-40) per frame in hdr10 video", .default_json = "true",
       .flag = "--no-dynamic-metadata", .sequence = true},
      {.path = "metadata.granularity", .type = T::choice, .sources = kSceneReferred,
       .doc = "Sequences: HDR10+ and Dolby Vision L1 values per scene or per frame", .choices = kGranularity,
       .default_json = "\"scene\"", .flag = "--metadata-granularity", .metavar = "G", .sequence = true},
      {.path = "metadata.hdr10plus_target_nits", .type = T::number, .sources = kSceneReferred,
       .doc = "Sequences: HDR10+ profile B, a Bezier tone curve per scene for a display of this peak",
       .unit = "cd/m2", .min = 100, .max = 10000, .default_doc = "none (profile A)", .flag = "--hdr10plus-target",
       .metavar = "NITS", .sequence = true},
      {.path = "present.live", .type = T::boolean, .sources = kSceneReferred,
       .doc = "Sequences: show each frame on the attached display as it is made (KMS page flips at fps; "
              "docs/displays.md)",
       .default_json = "false", .flag = "--present", .sequence = true},
      {.path = "present.pacing", .type = T::choice, .sources = kSceneReferred,
       .doc = "Sequences shown live: every-frame shows each frame (a renderer slower than fps), realtime drops "
              "late ones",
       .choices = kPacing, .default_json = "\"every-frame\"", .flag = "--pacing", .metavar = "P", .sequence = true},
      {.path = "present.buffers", .type = T::integer, .sources = kSceneReferred,
       .doc = "Sequences shown live: scan-out buffers, 2 (double) or 3 (triple buffering)", .min = 2, .max = 3,
       .default_json = "2", .flag = "--buffers", .metavar = "N", .sequence = true},
      {.path = "present.connector", .type = T::text, .sources = kSceneReferred,
       .doc = "Sequences shown live: the connector (e.g. HDMI-A-1)", .default_doc = "the first connected one",
       .flag = "--present-connector", .metavar = "NAME", .max_length = 64, .sequence = true},
      {.path = "png_level", .type = T::integer, .sources = kAllSources,
       .doc = "PNG deflate level: 0 stored, 1-3 fast, 4-9 smaller and much slower (docs/dump-format.md)", .min = 0,
       .max = 9, .default_json = "1", .flag = "--png-level", .metavar = "N", .query = "png_level"},
      {.path = "durable", .type = T::boolean, .sources = kAllSources,
       .doc = "fsync each file of a dump and its directory, so the files survive a power cut", .default_json = "false",
       .flag = "--durable", .query = "durable"},
      {.path = "dither", .type = T::boolean, .sources = kSceneReferred, .doc = "Ordered dither on code values",
       .default_json = "false", .flag = "--dither", .query = "dither"},
      {.path = "dump", .type = T::boolean, .sources = kAllSources,
       .doc = "Write the dump into the daemon's dump directory and answer its sidecar", .default_json = "false",
       .query = "dump", .reach = Reach::daemon},
      {.path = "name", .type = T::text, .sources = kAllSources,
       .doc = "Base name of a daemon dump ([A-Za-z0-9._-])", .default_doc = "generated", .query = "name",
       .reach = Reach::daemon},
      {.path = "timeout_s", .type = T::number, .sources = kAllSources,
       .doc = "Time limit of the request (at most the daemon's limits.max_request_seconds)", .unit = "s",
       .min = 1e-3, .max = 1e6, .default_doc = "limits.max_request_seconds", .query = "timeout_s",
       .reach = Reach::daemon},
      {.path = "threads", .type = T::integer, .sources = kAllSources,
       .doc = "Encoder threads, 0 = all cores (the daemon: [workers] encode_threads)", .min = 0, .max = 256,
       .default_json = "0", .flag = "--threads", .metavar = "N", .reach = Reach::cli},
      {.path = "backend", .type = T::choice, .sources = kRender,
       .doc = "GL backend (the daemon: [workers] backend)", .choices = kBackends, .default_json = "\"auto\"",
       .flag = "--backend", .metavar = "NAME", .reach = Reach::cli},
  };
}

const std::vector<Setting>& table() {
  static const std::vector<Setting> t = make_table();
  return t;
}

// --camera px,py,pz[:tx,ty,tz[:fov_deg]]
bool parse_triple(std::string_view s, json& out) {
  out = json::array();
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t end = i < 2 ? s.find(',', pos) : s.size();
    if (end == std::string_view::npos) return false;
    double v = 0;
    const auto part = s.substr(pos, end - pos);
    const auto [p, ec] = std::from_chars(part.data(), part.data() + part.size(), v);
    if (ec != std::errc() || p != part.data() + part.size()) return false;
    out.push_back(v);
    pos = end + 1;
  }
  return true;
}

json expand_camera(std::string_view text, std::string* error) {
  json cam = json::object();
  std::vector<std::string_view> parts;
  for (std::size_t pos = 0;;) {
    const auto colon = text.find(':', pos);
    parts.push_back(text.substr(pos, colon == std::string_view::npos ? std::string_view::npos : colon - pos));
    if (colon == std::string_view::npos) break;
    pos = colon + 1;
  }
  json v;
  if (parts.size() > 3 || !parse_triple(parts[0], v)) {
    *error = "expected px,py,pz[:tx,ty,tz[:fov_deg]]";
    return nullptr;
  }
  cam["position"] = v;
  if (parts.size() > 1) {
    if (!parse_triple(parts[1], v)) {
      *error = "the target is not tx,ty,tz";
      return nullptr;
    }
    cam["target"] = v;
  }
  if (parts.size() > 2) {
    double fov = 0;
    const auto [p, ec] = std::from_chars(parts[2].data(), parts[2].data() + parts[2].size(), fov);
    if (ec != std::errc() || p != parts[2].data() + parts[2].size()) {
      *error = "the field of view is not a number";
      return nullptr;
    }
    cam["fov_y_deg"] = fov;
  }
  return {{"camera", cam}};
}

json expand_ui_pos(std::string_view text, std::string* error) {
  const auto comma = text.find(',');
  long long xy[2] = {};
  const std::string_view parts[2] = {text.substr(0, comma),
                                     comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1)};
  for (int i = 0; i < 2; ++i) {
    const auto [p, ec] = std::from_chars(parts[i].data(), parts[i].data() + parts[i].size(), xy[i]);
    if (comma == std::string_view::npos || parts[i].empty() || ec != std::errc() ||
        p != parts[i].data() + parts[i].size()) {
      *error = "expected X,Y in whole pixels";
      return nullptr;
    }
  }
  return {{"ui", {{"x", xy[0]}, {"y", xy[1]}}}};
}

// --sky ELEV[,AZIM[,TURBIDITY]] (degrees): the Preetham sky and its sun.
json expand_sky(std::string_view text, std::string* error) {
  static constexpr const char* kKeys[] = {"sun_elevation_deg", "sun_azimuth_deg", "turbidity"};
  json sky = json::object();
  std::size_t pos = 0;
  for (int i = 0; i < 3; ++i) {
    const auto comma = text.find(',', pos);
    const std::string_view part = text.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos);
    double v = 0;
    const auto [p, ec] = std::from_chars(part.data(), part.data() + part.size(), v);
    if (part.empty() || ec != std::errc() || p != part.data() + part.size()) {
      *error = "expected ELEV[,AZIM[,TURBIDITY]] in degrees";
      return nullptr;
    }
    sky[kKeys[i]] = v;
    if (comma == std::string_view::npos) return {{"environment", {{"sky", sky}}}};
    pos = comma + 1;
  }
  *error = "expected at most three numbers, ELEV[,AZIM[,TURBIDITY]]";
  return nullptr;
}

constexpr std::string_view kSkyPaths[] = {"environment.sky.sun_elevation_deg", "environment.sky.sun_azimuth_deg",
                                          "environment.sky.turbidity"};
constexpr std::string_view kCameraPaths[] = {"camera.position", "camera.target", "camera.fov_y_deg"};
constexpr std::string_view kUiPosPaths[] = {"ui.x", "ui.y"};
const Composite kComposites[] = {
    {"--camera", "P[:T[:FOV]]", "Camera px,py,pz[:tx,ty,tz[:fov_deg]] (camera.position, .target, .fov_y_deg)",
     kRender, kCameraPaths, &expand_camera},
    {"--sky", "ELEV[,AZIM[,TURB]]", "Light by the Preetham sky and its sun (environment.sky.*)", kRender, kSkyPaths,
     &expand_sky},
    {"--ui-pos", "X,Y", "Overlay top-left in output pixels (ui.x, ui.y)", kSceneReferred, kUiPosPaths, &expand_ui_pos},
};

std::string range_text(const Setting& s) {
  switch (s.type) {
    case Type::number:
    case Type::integer: return fmt::format("[{:g}, {:g}]", s.min, s.max);
    case Type::choice:
    case Type::choice_list: {
      std::string c;
      for (auto v : s.choices) c += (c.empty() ? "" : ", ") + std::string(v);
      return c;
    }
    default: return "";
  }
}

std::string sources_text(Sources s) {
  std::string out;
  for (Source src : {Source::render, Source::encode, Source::pattern})
    if (applies(s, src)) out += (out.empty() ? "" : ", ") + std::string(to_string(src));
  return out;
}

}  // namespace

std::string_view to_string(Source s) {
  switch (s) {
    case Source::render: return "render";
    case Source::encode: return "encode";
    case Source::pattern: return "pattern";
  }
  return "?";
}

std::string_view to_string(Type t) {
  switch (t) {
    case Type::number: return "number";
    case Type::integer: return "integer";
    case Type::boolean: return "boolean";
    case Type::choice: return "choice";
    case Type::text: return "string";
    case Type::path: return "path";
    case Type::vec3: return "vec3";
    case Type::number_map: return "map of numbers";
    case Type::choice_list: return "list";
    case Type::base64: return "base64";
    case Type::scene: return "scene";
  }
  return "?";
}

nlohmann::json Setting::default_value() const { return json::parse(default_json); }

std::string Setting::default_text() const {
  if (!default_doc.empty()) return std::string(default_doc);
  const json v = default_value();
  return v.is_string() ? v.get<std::string>() : v.dump();
}

std::span<const Setting> settings() { return table(); }

const Setting* find_setting(std::string_view path) {
  for (const auto& s : table())
    if (s.path == path || (!s.alias.empty() && s.alias == path)) return &s;
  return nullptr;
}

bool is_group(std::string_view path) {
  if (path.empty()) return true;
  for (const auto& s : table())
    if (s.path.size() > path.size() && s.path.substr(0, path.size()) == path && s.path[path.size()] == '.') return true;
  return false;
}

std::span<const Composite> composites() { return kComposites; }

std::string settings_markdown() {
  std::string md =
      "| setting | CLI | query | type | unit | range | default | applies to | what |\n"
      "|---|---|---|---|---|---|---|---|---|\n";
  auto cell = [](std::string_view s) {
    std::string out;
    for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  for (const auto& s : table()) {
    std::string where = sources_text(s.sources);
    if (s.reach == Reach::daemon) where += " (daemon)";
    if (s.reach == Reach::cli) where += " (CLI)";
    if (s.sequence) where += " (sequences)";
    md += fmt::format("| `{}`{} | {} | {} | {} | {} | {} | {} | {} | {} |\n", s.path,
                      s.alias.empty() ? "" : fmt::format(" (or `{}`)", s.alias),
                      s.flag.empty() ? "" : fmt::format("`{}`", s.flag), s.query.empty() ? "" : fmt::format("`{}`", s.query),
                      to_string(s.type), s.unit, cell(range_text(s)), cell(s.default_text()), where, cell(s.doc));
  }
  md += "\nCLI options that set several settings at once:\n\n";
  for (const auto& c : kComposites) md += fmt::format("- `{} {}`: {}\n", c.flag, c.metavar, c.doc);
  return md;
}

nlohmann::json settings_json() {
  json out = json::array();
  for (const auto& s : table()) {
    json j = {{"path", s.path}, {"type", to_string(s.type)}, {"doc", s.doc}, {"applies_to", json::array()}};
    for (Source src : {Source::render, Source::encode, Source::pattern})
      if (s.takes(src)) j["applies_to"].push_back(to_string(src));
    if (s.sequence) j["sequence"] = true;
    if (!s.unit.empty()) j["unit"] = s.unit;
    if (s.type == Type::number || s.type == Type::integer) j["min"] = s.min, j["max"] = s.max;
    if (!s.choices.empty()) j["choices"] = std::vector<std::string>(s.choices.begin(), s.choices.end());
    j["default"] = s.default_value();
    if (!s.default_doc.empty()) j["default_doc"] = s.default_doc;
    if (!s.flag.empty()) j["cli"] = s.flag;
    if (!s.query.empty()) j["query"] = s.query;
    if (!s.alias.empty()) j["alias"] = s.alias;
    if (s.reach != Reach::everywhere) j["reach"] = s.reach == Reach::daemon ? "daemon" : "cli";
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace hdrd::job

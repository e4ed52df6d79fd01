// Exposure (REFERENCE.md §1.2): turns scene values into relative values where mid grey
// = 0.18 and diffuse white = 1.0. `compensation_ev` is applied last in every mode.
#pragma once

#include <optional>
#include <span>
#include <string_view>

#include "encode/colour/color.hpp"
#include "encode/image.hpp"
#include "encode/result.hpp"

namespace hdrd::exposure {

enum class Mode { manual, camera, log_average, histogram, light };
std::string_view to_string(Mode m);
std::optional<Mode> parse_mode(std::string_view s);  // "manual", "camera", "log-average", "histogram", "light"

struct Settings {
  Mode mode = Mode::manual;
  double compensation_ev = 0;          // + brightens, in stops
  double gain = 1.0;                   // manual: extra linear gain
  // camera: EV100 = log2(N^2 / t * 100 / S), or given directly
  std::optional<double> ev100;
  double aperture_f = 16.0;
  double shutter_s = 1.0 / 125.0;
  double iso = 100.0;
  // histogram: the percentile metered and the value it maps to (median -> 0.18 by default)
  double percentile = 50.0;
  double percentile_target = 0.18;
  double ignore_dark_fraction = 0.0;   // fraction of darkest metered pixels ignored
  double ignore_bright_fraction = 0.02;  // fraction of brightest pixels ignored (robust to a few highlights)
  // light-based: the dominant illuminance E in lux (from the renderer or given)
  std::optional<double> illuminance_lux;
  // sequences (encode/tone/adaptation.hpp): time constant of exponential adaptation in
  // stops, both directions (0 = none: every frame exposed from its own metering); the
  // per-direction constants override it when given.
  double adaptation_time_s = 0.0;
  std::optional<double> adaptation_brighten_time_s;  // while the exposure rises (into the dark)
  std::optional<double> adaptation_darken_time_s;    // while it falls (into the light)
};

// What the metering found; scale multiplies scene values (absolute cd/m2 for absolute
// input, relative otherwise) into relative values, compensation included.
struct Metering {
  double scale = 1.0;
  double metered = 0.0;             // the metered quantity (log-average, percentile, E, ...)
  std::optional<double> ev100;      // camera modes
};

inline constexpr double kMidGrey = 0.18;
inline constexpr double kLogAverageEpsilon = 1e-4;  // in relative units (or nits/10000)

double ev100_from_camera(double aperture_f, double shutter_s, double iso);
// Lagarde & de Rousiers 2014: saturation-based sensitivity, q = 0.65, S = 100 -> 1.2.
double scale_from_ev100(double ev100);

// Meters scene luminance samples in cd/m2 (Rec.2020 Y of the input converted to nits:
// absolute input via its white luminance, relative input as value * paper white) and
// returns the scale from cd/m2 to relative values. Manual mode: gain / paper white, so a
// relative input passes unchanged and absolute paper-white luminance becomes 1.0.
// Samples that are not finite are ignored. `luminance` may be empty for manual, camera
// and light modes.
Result<Metering> meter(const Settings& s, std::span<const float> luminance_nits, double paper_white_nits);

}  // namespace hdrd::exposure

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
  // histogram (Unreal's auto exposure): a log2 luminance histogram; the darkest and the
  // brightest fractions are ignored (Unreal's low/high percent 80 and 98.3: the window
  // [80 %, 98.3 %]); what is left is averaged in stops (no percentile given) or read at a
  // percentile of the window (Valve: the median), and that maps to percentile_target.
  std::optional<double> percentile;
  double percentile_target = 0.18;
  double ignore_dark_fraction = 0.80;    // fraction of darkest metered pixels ignored
  double ignore_bright_fraction = 0.017;  // fraction of brightest pixels ignored (the sun, a few highlights)
  // Metered modes (histogram, log-average): the exposure is that of a camera whose EV100
  // is clamped to [min_ev100, max_ev100] (Unreal's min/max EV100), so a black frame is
  // not amplified without bound and a sun-filled one not darkened without bound.
  double min_ev100 = -6;
  double max_ev100 = 20;
  // light-based: the dominant illuminance E in lux (from the renderer or given)
  std::optional<double> illuminance_lux;
  // sequences (encode/tone/adaptation.hpp): time constant of exponential adaptation in
  // stops, both directions (0 = none: every frame exposed from its own metering); the
  // per-direction constants override it when given.
  double adaptation_time_s = 0.0;
  // (job/ gives sequences the table's defaults: brighten 1 s, darken 1/3 s, Unreal's speed
  // down 1 and up 3.)
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

// The camera EV100 whose exposure (scale_from_ev100) is `scale` cd/m2 -> relative.
double ev100_from_scale(double scale);
// The histogram statistic: the log2-average of the luminance between the `dark` and
// `1 - bright` fractions of the samples, or (percentile given) that percentile of the
// window, in cd/m2; 0 when nothing finite. From a 1/8-stop log2 histogram
// (temporal::LuminanceHistogram), as Unreal meters: the average within 1/16 stop, a
// percentile within its bin (1/8 stop).
double histogram_window_nits(std::span<const float> luminance_nits, double dark, double bright,
                             std::optional<double> percentile);

double ev100_from_camera(double aperture_f, double shutter_s, double iso);
// Lagarde & de Rousiers 2014: saturation-based sensitivity, q = 0.65, S = 100 -> 1.2.
double scale_from_ev100(double ev100);

// Meters scene luminance samples in cd/m2 (Rec.2020 Y of the input converted to nits:
// absolute input via its white luminance, relative input as value * paper white) and
// returns the scale from cd/m2 to relative values. Manual mode: gain / paper white, so a
// relative input passes unchanged and absolute paper-white luminance becomes 1.0.
// Samples that are not finite are ignored. Histogram and log-average results are clamped
// to [min_ev100, max_ev100] before the compensation (ev100 then says where it landed). `luminance` may be empty for manual, camera
// and light modes.
Result<Metering> meter(const Settings& s, std::span<const float> luminance_nits, double paper_white_nits);

}  // namespace hdrd::exposure

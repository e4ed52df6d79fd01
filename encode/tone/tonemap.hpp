// Tone curves as data (REFERENCE.md §1.3, §4): every curve is a registry entry with a
// name, description, source, parameters (range + default), domain, map and, where one
// exists, an inverse. Curves are peak-aware: they map a relative scene value x (1.0 =
// diffuse white) to display luminance y in units of paper white, y in [0, peak/paper_white].
// nits = y * paper_white_nits. No curve lifts black (the display's black level is the
// encoder's business), with one opt-in exception: bt2390 with black_lift = 1 maps the
// source black to the display black, exactly as BT.2390 §5.4 step E3 does.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "encode/colour/color.hpp"
#include "encode/display_target.hpp"
#include "encode/result.hpp"

namespace hdrd::tonemap {

struct ParamSpec {
  std::string_view name;
  std::string_view description;
  double min, max, default_value;
};

// The display a curve maps to.
struct Display {
  double peak_nits = 1000;
  double black_nits = 0;
  double paper_white_nits = 203;
  double max_y() const { return peak_nits / paper_white_nits; }  // display maximum, paper-white units
};

// How a scalar curve is applied to RGB (working space, linear Rec.2020).
enum class Apply {
  per_channel,  // each channel through the curve (hue shifts toward white when bright)
  max_rgb,      // ratio curve(max)/max on all channels: keeps channel ratios, never above peak
  luminance,    // ratio curve(Y)/Y with Rec.2020 luminance; may leave the gamut (then gamut-mapped)
  rgb,          // the curve is an RGB operator of its own (AgX, ICtCp mapper, PBR Neutral, OCIO)
};
std::string_view to_string(Apply a);
std::optional<Apply> parse_apply(std::string_view s);

using ParamValues = std::map<std::string, double>;

// A curve prepared for one display and parameter set: cheap to evaluate, thread-safe.
class Curve {
 public:
  virtual ~Curve() = default;
  // Scalar map y = f(x), x >= 0. For rgb-only curves: the achromatic response.
  virtual double map(double x) const = 0;
  // x = f^-1(y) where the curve is invertible on [0, max_y); nullopt otherwise.
  virtual std::optional<double> inverse(double y) const { return std::nullopt; }
  // RGB operator (relative Rec.2020 in, paper-white units Rec.2020 out). The default
  // applies the scalar map according to `apply`: per channel, or the ratio shape(k) / k of
  // k = max(RGB) or luminance on every channel, then lift() per channel.
  virtual color::Vec3 map_rgb(color::Vec3 rgb, Apply apply) const;

  // Where map's slope jumps (a clamp at the white point, a segment join that is not C1, the
  // source peak of bt2390), in relative scene units: the fast path's tables put a node on
  // each (encode/kernel/float_lut.hpp). tests/encode/tone finds kinks numerically and checks
  // the tables at and around every one, declared or not.
  virtual std::vector<double> kinks() const { return {}; }

  // A curve whose last step is a per-channel black-level lift (bt2390 with black_lift:
  // BT.2390 §5.4 step E3) is map(x) = lift(shape(x)); ratio applications take the ratio of
  // the shape and lift each channel after it, as the report lifts each of R', G', B' (black,
  // and the zero channels of near-black colours, get the display's black). lift_kinks()
  // are lift's kinks in paper-white units.
  virtual bool lifts_black() const { return false; }
  virtual double shape(double x) const { return map(x); }
  virtual double lift(double y) const { return y; }
  virtual std::vector<double> lift_kinks() const { return {}; }
};

struct ToneCurveInfo {
  std::string_view name;
  std::string_view description;
  std::string_view source;  // citation
  std::vector<ParamSpec> params;
  Apply default_apply;
  bool scalar;              // false: only map_rgb is meaningful per pixel (Apply::rgb)
  bool has_inverse;
  // Claims x = 1 -> y = 1 (reference white kept) when peak >= 2 x paper white.
  bool keeps_reference_white;
  std::unique_ptr<Curve> (*prepare)(const Display& display, const ParamValues& params);
};

// All registered curves in a stable order (built-ins first).
std::span<const ToneCurveInfo> curves();
const ToneCurveInfo* find_curve(std::string_view name);
// Adds a curve at run time (e.g. OpenColorIO ACES output transforms). Returns false if the
// name is taken. Not thread-safe against concurrent lookups: register at start-up.
bool register_curve(ToneCurveInfo info);

// Validates names and ranges and fills in defaults: one function clamps nothing silently;
// out-of-range values are errors naming the parameter.
Result<ParamValues> resolve_params(const ToneCurveInfo& info, const ParamValues& given);

// Prepares a curve by name for a display, with validated parameters.
Result<std::unique_ptr<Curve>> prepare(std::string_view name, const Display& display,
                                       const ParamValues& params = {});

// Where f's slope jumps on [lo, hi] (lo > 0), found numerically: for checks (tests and
// `hdrd selftest` compare the fast path's tables at and around each kink, declared by the
// curve or not). f is sampled 1024 times per octave; an interval whose slope change is 50
// times that of the intervals two away on both sides is a kink (a C1 join with a jump in
// curvature is not), placed where the lines through the samples on either side meet.
std::vector<double> find_kinks(const std::function<double(double)>& f, double lo, double hi);

// The default curve of each mode (documented in docs/tone-mapping.md): keeps reference
// white whenever peak >= 2 x paper white.
std::string_view default_curve(Mode mode);

}  // namespace hdrd::tonemap

// Gamut mapping as a family (issue 31), after tone mapping: display light in the working
// space (linear Rec.2020, D65, cd/m2) -> the target gamut's RGB inside [0, peak]^3. The
// names are libplacebo's (src/gamut_mapping.c); the maths is hdrd's, in ICtCp (BT.2100):
// every map but clip and highlight keeps the ICtCp hue angle h = atan2(Cp, Ct), and works on
// intensity I and chroma C = hypot(Ct, Cp) at that hue.
//   clip        per-channel clip in the target (hue and lightness shift)
//   ictcp       today's default: constant I, chroma reduced to the target's boundary, for
//               colours outside only. `desaturate` (libplacebo's name for the same) is an alias.
//   relative    colorimetric, hue-preserving clip toward the target's cusp: colours outside
//               move along the line to the grey at the intensity of the most saturated
//               colour the target has at that hue (the cusp, CIE 156's cusp-directed clip)
//   absolute    as relative, without adapting the target's white point: a display whose
//               white is not D65 shows D65 as D65 (tinted in its own terms)
//   perceptual  soft knee toward the boundary: chroma below 70 % of the target's boundary
//               is kept; above it the source gamut's boundary chroma Cs is rolled into the
//               target's Ct by y = x / (1 + x (1/a - 1/b)) (x = C - k, a = Ct - k, b = Cs - k,
//               k = 0.7 Ct: C1 at the knee, Cs lands on Ct); a source that fits is untouched
//   saturation  chroma scaled by Ct / Cs where the source reaches beyond the target: the
//               source's most saturated colours become the target's, at each I and h
//   linear      one chroma scale for the whole picture, the least cusp ratio over the hues,
//               so the source's cusps all fit
//   darken      one light scale for the whole picture so the source's primaries and
//               secondaries at the peak fit the target, then relative
//   highlight   colours outside are marked: hue turned half a turn, chroma x 1.2, 0.1 brighter
//               in I (then fitted at constant I); colours inside are kept
// Source and target are any RGB gamuts: the source as its RGB -> working matrix (an input's
// primaries), the target as primaries (a container, or an EDID's, white point included).
// Every map except absolute compares the two with their whites adapted to D65 (Bradford).
#pragma once

#include <array>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "encode/colour/color.hpp"

namespace hdrd {

enum class GamutMapping { ictcp, clip, perceptual, relative, saturation, absolute, darken, highlight, linear };
// Every accepted name in enum order, then the alias "desaturate" (= ictcp): the settings
// table's choices.
inline constexpr std::array<std::string_view, 10> kGamutMappingNames = {
    "ictcp", "clip", "perceptual", "relative", "saturation", "absolute", "darken", "highlight", "linear", "desaturate"};
std::string_view to_string(GamutMapping g);
std::optional<GamutMapping> parse_gamut_mapping(std::string_view s);

namespace gamut {

// Colours inside [lo, hi] per channel are "inside": hi = peak (1 + tolerance), lo = -tolerance peak.
inline constexpr double kDefaultTolerance = 1e-4;

// Whether c lies in [-tol peak, peak (1 + tol)]^3, and c clamped to [0, peak]^3.
bool in_cube(color::Vec3 c, double peak, double tol);
color::Vec3 clamp_to(color::Vec3 c, double peak);

// Constant ICtCp intensity (capped at the peak's), chroma reduced until `to_target` of the
// colour fits [0, peak]^3: REFERENCE.md §1.5, the `ictcp` map. Shared by the pipeline.
color::Vec3 desaturate(color::Vec3 working_nits, const color::Mat3& to_target, double peak_nits);

class Mapper {
 public:
  // container: when given, the target is a display's gamut inside that signal container
  // (an EDID's primaries): map() returns the container's RGB of the mapped colour, and every
  // colour goes through map() (inside the container is not inside the display).
  Mapper(GamutMapping g, const color::Mat3& source_to_working, const color::Primaries& target, double peak_nits,
         double tolerance = kDefaultTolerance, std::optional<color::Primaries> container = std::nullopt);
  // Working light -> target RGB light inside [0, peak]^3 (the container's RGB of it with a container).
  color::Vec3 map(color::Vec3 working_nits) const;
  // True when colours already inside the target come back as working_to_target() of them
  // (so only the colours outside need map()): clip, ictcp, relative, absolute, highlight,
  // and the others where the source gamut lies inside the target's.
  bool keeps_inside() const { return keeps_inside_; }
  const color::Mat3& working_to_target() const { return w2t_; }
  const color::Mat3& target_to_working() const { return t2w_; }
  GamutMapping method() const { return g_; }
  double linear_gain() const { build_tables(); return chroma_gain_; }  // linear's chroma scale
  double darken_gain() const { return light_gain_; }   // darken's light scale

 private:
  struct Lch {
    double i, c, h;
  };
  bool inside(const color::Mat3& to_rgb, color::Vec3 working) const;
  color::Vec3 at(double i, double c, double h) const;  // ICtCp polar -> working nits
  double boundary(const color::Mat3& to_rgb, double i, double h) const;  // exact, by bisection
  double table(const std::vector<float>& t, double i, double h) const;   // bilinear
  double cusp_intensity(double h) const;
  color::Vec3 clip_toward(Lch c, double target_i) const;  // largest s on (target_i + s (I - target_i), s C)
  color::Vec3 finish(color::Vec3 working) const;          // -> target RGB, clamped
  void build_tables() const;
  color::Vec3 map_to_target(color::Vec3 working_nits) const;                              // once, on the first colour that needs them

  GamutMapping g_;
  color::Mat3 w2t_, t2w_, w2s_;
  double peak_, tol_, i_peak_;
  bool keeps_inside_ = true;
  bool source_fits_ = false, local_ = true;  // local_: colours inside the target are kept
  std::optional<color::Mat3> to_container_;
  double light_gain_ = 1;
  // Boundary chroma of the target and the source on a grid of kI intensities x kH hues,
  // each hue's cusp intensity (target) and linear's chroma scale: built by build_tables()
  // (~0.1 s) the first time a colour needs them (where the source fits, rarely or never).
  static constexpr int kI = 129, kH = 256;
  mutable std::once_flag tables_once_;
  mutable std::vector<float> target_c_, source_c_, cusp_i_;
  mutable double chroma_gain_ = 1;
};

}  // namespace gamut
}  // namespace hdrd

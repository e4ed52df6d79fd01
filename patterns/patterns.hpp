// Standard HDR test patterns (docs/patterns.md). Patterns are display-referred: each is
// built as display light (linear Rec.2020, cd/m2) and sent through the encoder's own
// signal stage with the `clip` tone curve, so a pattern level L lands on exactly the code
// the encoder gives L. BT.2111 colour bars are defined as code values and are written as
// codes directly.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "encode/colour/color.hpp"
#include "encode/display_target.hpp"
#include "encode/frame.hpp"
#include "encode/image.hpp"
#include "encode/result.hpp"

namespace hdrd::patterns {

struct PatternInfo {
  std::string_view name;
  std::string_view description;
  std::string_view source;
};
std::span<const PatternInfo> patterns();
const PatternInfo* find_pattern(std::string_view name);

struct PatternOptions {
  int width = 1920;
  int height = 1080;
  double level_nits = 0;      // window level / clipping point; 0: the display's peak
  double area_percent = 10;   // window area, percent of the frame
  int steps = 0;              // pq-ramp / near-black / sdr-grey steps; 0: the pattern's default
  bool labels = true;         // draw the built-in bitmap font labels
};

// sdr-shadows: rows top to bottom decode the same SDR signals (sdr_shadow_signals(), 0 to
// 20 %) with these EOTFs, each placed at the SDR white (sdr_white_nits in HDR modes, the
// peak in SDR modes); each row's patches span the columns right of a label strip of
// width / 8, the rows split the height above a label strip of height / 8 in thirds.
inline constexpr SdrEotf kSdrShadowRows[3] = {SdrEotf::srgb, SdrEotf::gamma22, SdrEotf::bt1886};
const std::vector<double>& sdr_shadow_signals();

// Display light of a display-referred pattern (all but bt2111): RGBA float, linear
// Rec.2020, cd/m2, rows top-down.
Result<Image> pattern_nits(std::string_view name, const DisplayTarget& target, const PatternOptions& options);

// The encoded pattern; frame.settings["pattern"] says what it is. `keep_display_nits`
// fills frame.display_nits (needed for the EXR dump).
Result<EncodedFrame> make_pattern(std::string_view name, const DisplayTarget& target, const PatternOptions& options,
                                  bool keep_display_nits = true);

// Display light (linear Rec.2020 cd/m2) through the encoder with the clip curve, manual
// exposure at 0 EV and clip gamut mapping: every level at or below the peak keeps its
// luminance.
Result<EncodedFrame> encode_display_nits(const Image& rec2020_nits, const DisplayTarget& target,
                                         bool keep_display_nits = true);

// ---- ITU-R BT.2111-2 colour bars ---------------------------------------------------------
enum class Bt2111System { pq, hlg };

struct Code3 {
  int r = 0, g = 0, b = 0;
  friend bool operator==(Code3, Code3) = default;
};

// The 10-bit narrow-range R'G'B' code of each named BT.2111-2 level ("100% yellow",
// "75% white", "709 red", ...), generated from the signal levels the standard defines.
Code3 bt2111_code(Bt2111System system, std::string_view level);
// All level names the pattern uses, top row first.
std::vector<std::string> bt2111_levels();

// The whole pattern as 10-bit codes (row-major, width x height), the 1920-wide layout
// scaled to the requested size.
std::vector<Code3> bt2111_codes(Bt2111System system, int width, int height);

// A frame whose codes are given directly (XBGR2101010): display_nits, signal16, content
// light and mastering metadata derived from them. Target mode hdr10/hlg/10-bit SDR.
Result<EncodedFrame> frame_from_codes(const std::vector<Code3>& codes, int width, int height,
                                      const DisplayTarget& target, bool keep_display_nits = true);


}  // namespace hdrd::patterns

// The EOTF SDR content is decoded with when it is placed in an HDR frame (the UI overlay
// and any SDR image): the display the content was mastered on. IEC 61966-2-1's piecewise
// sRGB curve is the file format's definition, but much SDR content is graded on displays
// that decode with a pure 2.2 power, and broadcast SDR on BT.1886 (2.4). The three differ
// almost only near black (sRGB's linear toe lifts the shadows against 2.2: an 8-bit code
// of 10 is 0.30 % of white in sRGB, 0.080 % in 2.2, 0.042 % in 2.4), which is where SDR in
// HDR modes is seen to be crushed or lifted. The light is relative to SDR white: 1.0 lands
// on sdr_white_nits (or ui_white_nits for the UI).
#pragma once

#include <optional>
#include <string_view>

namespace hdrd {

enum class SdrEotf {
  srgb,     // IEC 61966-2-1 piecewise curve (linear toe below 0.04045)
  gamma22,  // a pure 2.2 power
  bt1886,   // ITU-R BT.1886 with a zero black level: a pure 2.4 power relative to white
};

std::string_view to_string(SdrEotf e);
std::optional<SdrEotf> parse_sdr_eotf(std::string_view s);  // "srgb", "gamma22", "bt1886"

// Signal V in [0, 1] -> relative light in [0, 1] (1 = SDR white); and its inverse.
// Outside [0, 1] both clamp.
double sdr_eotf(SdrEotf e, double signal);
double sdr_inverse_eotf(SdrEotf e, double linear);

}  // namespace hdrd

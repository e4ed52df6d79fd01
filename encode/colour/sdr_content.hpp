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

// How SDR light lands in an HDR frame (ui.inverse_tonemap; docs/encoding.md).
enum class InverseTonemap {
  linear,   // nits = light * white (today's mapping; bit-identical)
  bt2446c,  // ITU-R BT.2446-1 method C's inverse: linear to the knee, exponential expansion above
};

std::string_view to_string(InverseTonemap m);
// "linear", "bt2446c"; "bt2446a-inverse" is accepted as an alias of bt2446c.
std::optional<InverseTonemap> parse_inverse_tonemap(std::string_view s);

// BT.2446-1 method C's knee, relative to SDR white: Y_SDR,ip = 58.535 of a 100 cd/m2 white, and its k3.
inline constexpr double kBt2446cKnee = 0.58535;
inline constexpr double kBt2446cK3 = 0.74204;

// The one mapping every caller uses: light relative to SDR white (1 = white, from sdr_eotf)
// -> display nits, for SDR white `white` on a display of peak `peak` cd/m2. `linear` is
// light * white. `bt2446c` is linear (light * white) up to the knee, and above it
// Y = (exp((y - k4) / k2) + k3) * Y_ip (Y_ip = knee * white), with k4 = knee - k2 ln(1 - k3)
// (continuous at the knee) and k2 chosen so that y = 1 lands on the peak, never above: monotone,
// bounded. With peak <= Y_ip there is no headroom and it is min(light * white, peak).
double sdr_light_to_nits(InverseTonemap m, double light, double white, double peak);

}  // namespace hdrd

// Decoding a frame's codes back to display light, written from the standards with the
// encode module's transfer functions (never its tables): the oracle the display-mode
// suite measures frames with.
#pragma once

#include <cstdint>

#include "encode/colour/color.hpp"
#include "encode/display_target.hpp"
#include "encode/frame.hpp"

namespace hdrd::patterns {

// One pixel's channel codes: 10-bit (XBGR2101010), 8-bit (XRGB8888) or, for scRGB, the
// half-float values as read (not codes).
struct PixelSignal {
  int code[3] = {0, 0, 0};
  double scrgb[3] = {0, 0, 0};
};
PixelSignal read_pixel(const EncodedFrame& frame, int x, int y);

// Signal E' of one channel code for the target's bits and range (BT.2100 Table 9).
double code_to_signal(const DisplayTarget& t, int code);

// Display light of one pixel in the container primaries, cd/m2:
//  hdr10: ST 2084 EOTF per channel; hlg: BT.2100 HLG EOTF at the target peak and black;
//  scrgb: value x 80 (IEC 61966-2-2); sdr: sRGB / gamma 2.2 EOTF x peak; sdr-bt1886: BT.1886.
color::Vec3 decode_pixel(const EncodedFrame& frame, int x, int y);
color::Vec3 decode_codes(const DisplayTarget& t, const int code[3]);

// IEEE 754 binary16 to float (scRGB buffers).
float half_bits_to_float(std::uint16_t h);

}  // namespace hdrd::patterns

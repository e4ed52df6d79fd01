// R'G'B' codes of an EncodedFrame -> Y'CbCr 4:2:0 planes, the form video encoders take.
// Non-constant luminance (BT.2020 §4 / BT.2100 Table 6 for hdr10 and hlg, BT.709 for SDR):
//   Y' = Kr R' + Kg G' + Kb B',  Cb = (B' - Y') / (2 (1 - Kb)),  Cr = (R' - Y') / (2 (1 - Kr))
// on the non-linear signals E' decoded from the frame's codes (its own range), quantised
// (BT.2100 Table 9) narrow: Y = round((219 Y' + 16) 2^(n-8)), C = round((224 C + 128) 2^(n-8));
// full: Y = round((2^n - 1) Y'), C = round((2^n - 1) C + 2^(n-1)); clipped to [0, 2^n - 1].
// Chroma is sited as H.273 / HEVC chroma_sample_loc_type 0 (AV1 CSP_VERTICAL, "left"):
// co-sited with even luma columns, midway between the two rows, so each chroma sample is
// the [1 2 1] / 4 filter across columns 2i-1, 2i, 2i+1 (edge replicated) averaged over
// rows 2j and 2j+1, applied to R'G'B' before the matrix (both are linear, so this equals
// filtering Cb and Cr). Every operation is linear in the codes, so the kernel folds the
// decoding, the matrix and the quantisation into one multiply-add per sample, in double.
#pragma once

#include <cstddef>
#include <cstdint>

#include "encode/colour/color.hpp"
#include "encode/display_target.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::video {

struct YcbcrFormat {
  int bits = 10;                          // 10 (from XBGR2101010) or 8 (from XRGB8888): the input's depth
  Range range = Range::narrow;            // of the Y'CbCr codes
  color::Vec3 luma = color::kRec2020Luma;  // Kr, Kg, Kb
};
// Rec.2020 weights for hdr10/hlg, Rec.709 for SDR; bits from the frame's DRM format.
// Errors for scRGB (linear FP16 has no Y'CbCr form) and formats it cannot read.
Result<YcbcrFormat> ycbcr_format_for(const EncodedFrame& frame, Range range);

// One plane: bits 10 -> std::uint16_t samples (native endian, yuv420p10), 8 -> std::uint8_t.
struct Plane {
  std::uint8_t* data = nullptr;
  std::ptrdiff_t stride_bytes = 0;
};
struct Planes420 {
  Plane y, cb, cr;  // y: width x height; cb, cr: width/2 x height/2
};

// Converts the frame (even width and height) into the planes. Checks the frame first.
Result<void> rgb_to_ycbcr420(const EncodedFrame& frame, const YcbcrFormat& format, const Planes420& out);

}  // namespace hdrd::video

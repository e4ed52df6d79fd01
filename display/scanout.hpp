// Turning an encoded frame into something KMS can scan out and signal correctly:
//  - scRGB (FP16 linear, 1.0 = 80 cd/m2) has no KMS colorimetry/EOTF to describe it, so it
//    is converted to HDR10 (Rec.2020 PQ, XBGR2101010) with MaxCLL/MaxFALL measured on the
//    result, or refused, or (opt-in) passed through as raw FP16 for drivers that treat FP16
//    planes as scRGB;
//  - KMS RGB scan-out is full range, so narrow-range codes are expanded to full range.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

enum class ScrgbPolicy { convert, refuse, passthrough };
std::optional<ScrgbPolicy> parse_scrgb_policy(std::string_view s);  // "convert", "refuse", "passthrough"

struct ScanoutFrame {
  EncodedFrame frame;               // full range, a fourcc KMS takes
  std::vector<std::string> notes;   // conversions applied, one line each
};

// Bytes per pixel of the three scan-out formats, 0 for anything else.
int scanout_bytes_per_pixel(std::uint32_t fourcc);

// Checks sizes, stride and fourcc against the mode (one line naming the problem).
Result<void> check_frame(const EncodedFrame& frame);

Result<ScanoutFrame> prepare_for_scanout(const EncodedFrame& frame, ScrgbPolicy policy);

// scRGB FP16 (Rec.709 linear, 1.0 = 80 cd/m2) -> HDR10: Rec.2020 (BT.2087 matrix derived
// from the primaries), clipped to [0, 10000] cd/m2, PQ, 10-bit full range, XBGR2101010.
Result<EncodedFrame> scrgb_to_hdr10(const EncodedFrame& frame);

// Narrow-range XBGR2101010 / XRGB8888 codes -> full range (BT.2100 Table 9 inverted).
Result<EncodedFrame> narrow_to_full_range(const EncodedFrame& frame);

}  // namespace hdrd::display

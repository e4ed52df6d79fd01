// Internal helpers shared by the encode/io_*.cpp files (not part of the public interface).
#pragma once

#include <cstdint>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::io::detail {

// Bytes per pixel of the DRM formats hdrd produces; 0 for any other fourcc.
int bytes_per_pixel(std::uint32_t drm_fourcc);

// "XB30" for DRM_FORMAT_XBGR2101010, ...: the four characters of the code.
std::string fourcc_string(std::uint32_t code);

// Checks that a frame is self-consistent before it is written: size limits, a DRM
// format that fits the mode, stride >= width * bytes per pixel, data = stride * height
// bytes, and signal16 either empty or width * height * 3 samples.
Result<void> check_frame(const EncodedFrame& frame);

}  // namespace hdrd::io::detail

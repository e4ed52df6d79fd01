// Internal helpers shared by the encode/io_*.cpp files (not part of the public interface).
#pragma once

#include <cstdint>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::io::detail {

// Bytes per pixel of the DRM formats hdrd produces; 0 for any other fourcc.
int bytes_per_pixel(std::uint32_t drm_fourcc);

// Checks that a frame is self-consistent before it is written: size limits, a DRM
// format that fits the mode, stride >= width * bytes per pixel, data = stride * height
// bytes, and signal16 either empty or width * height * 3 samples.
Result<void> check_frame(const EncodedFrame& frame);

}  // namespace hdrd::io::detail

// In-memory images. Rows are top-down; pixels interleaved RGBA.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "encode/result.hpp"

namespace hdrd {

// Limits every reader and allocator checks before allocating (absurd sizes are errors).
inline constexpr int kMaxImageDimension = 16384;
inline constexpr std::int64_t kMaxImagePixels = 16384LL * 8192LL;  // 128 Mpx (8K x 16K)

Result<void> check_image_size(std::int64_t width, std::int64_t height);

// Linear light, float32 RGBA. What a value means (relative, absolute nits, which
// primaries) is carried by whoever holds the image, e.g. SceneImage below.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0.0f) {}
  std::size_t pixel_count() const { return static_cast<std::size_t>(width) * height; }
  float* px(int x, int y) { return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4; }
  const float* px(int x, int y) const {
    return rgba.data() + (static_cast<std::size_t>(y) * width + x) * 4;
  }
};

// Half-float RGBA (IEEE binary16 bits), as a GPU RGBA16F target reads back.
struct ImageHalf {
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> rgba;

  ImageHalf() = default;
  ImageHalf(int w, int h) : width(w), height(h), rgba(static_cast<std::size_t>(w) * h * 4, 0) {}
  std::size_t pixel_count() const { return static_cast<std::size_t>(width) * height; }
};

// Straight-alpha sRGB-encoded 8- or 16-bit RGBA overlay as decoded from a PNG,
// normalised to [0,1] floats (still sRGB-encoded; the compositor linearises).
struct OverlayImage {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;  // non-linear sRGB values and alpha in [0,1]
  bool premultiplied = false;
};

// IEEE binary16 <-> float, the one scalar conversion (the SIMD kernel has its own vector
// form, tested against this): round to nearest even, overflow to Inf, NaN kept NaN.
std::uint16_t float_to_half(float f);
float half_to_float(std::uint16_t h);

}  // namespace hdrd

#include "encode/image.hpp"

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <cstdint>

namespace hdrd {

Result<void> check_image_size(std::int64_t width, std::int64_t height) {
  if (width <= 0 || height <= 0)
    return make_error("image.size", fmt::format("image size {}x{} is empty", width, height));
  if (width > kMaxImageDimension || height > kMaxImageDimension)
    return make_error("image.size", fmt::format("image size {}x{} exceeds the limit of {} pixels per side",
                                                width, height, kMaxImageDimension));
  if (width * height > kMaxImagePixels)
    return make_error("image.size", fmt::format("image size {}x{} exceeds the limit of {} pixels",
                                                width, height, kMaxImagePixels));
  return {};
}

// IEEE binary16 conversions (round to nearest even; overflow to Inf; NaN kept NaN).
std::uint16_t float_to_half(float f) {
  const std::uint32_t x = std::bit_cast<std::uint32_t>(f);
  const std::uint32_t sign = (x >> 16) & 0x8000u;
  const std::uint32_t absx = x & 0x7FFFFFFFu;
  if (absx >= 0x7F800000u) return static_cast<std::uint16_t>(sign | (absx > 0x7F800000u ? 0x7E00u : 0x7C00u));
  if (absx >= 0x477FF000u) return static_cast<std::uint16_t>(sign | 0x7C00u);  // rounds to >= 65520: Inf
  if (absx < 0x38800000u) {  // subnormal half (or zero)
    const float a = std::bit_cast<float>(absx);
    return static_cast<std::uint16_t>(sign | static_cast<std::uint32_t>(std::nearbyint(a * 16777216.0f)));
  }
  const std::uint32_t mant_odd = (absx >> 13) & 1u;
  const std::uint32_t rounded = absx + 0xC8000FFFu + mant_odd;  // rebias exponent (-112 << 23) and round
  return static_cast<std::uint16_t>(sign | (rounded >> 13));
}

float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = (static_cast<std::uint32_t>(h) & 0x8000u) << 16;
  const std::uint32_t exp = (h >> 10) & 0x1Fu, mant = h & 0x3FFu;
  if (exp == 0) {
    const float v = static_cast<float>(mant) * (1.0f / 16777216.0f);
    return sign ? -v : v;
  }
  if (exp == 31) return std::bit_cast<float>(sign | 0x7F800000u | (mant << 13));
  return std::bit_cast<float>(sign | ((exp + 112) << 23) | (mant << 13));
}

}  // namespace hdrd

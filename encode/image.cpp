#include "encode/image.hpp"

#include <fmt/format.h>

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

}  // namespace hdrd

#include "encode/io/digest.hpp"

#include <xxhash.h>

#include <fmt/format.h>

namespace hdrd::io {

std::string content_digest(std::string_view bytes) {
  const XXH128_hash_t h = XXH3_128bits(bytes.data(), bytes.size());
  return fmt::format("{:016x}{:016x}", h.high64, h.low64);
}

}  // namespace hdrd::io

// Fuzz target: any bytes -> shading::read_radiance_hdr_memory (environment maps from
// requests and files). It must never crash, hang or allocate beyond what the data can
// fill; every failure is an Error with a one-line message, and a successful read is
// self-consistent (finite, non-negative values, the stated size).
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "shading/radiance_hdr.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto r = hdrd::shading::read_radiance_hdr_memory({data, size});
  if (!r.ok()) {
    if (r.error().message.empty() || r.error().message.find('\n') != std::string::npos) std::abort();
    return 0;
  }
  const hdrd::Image& img = r->image;
  if (img.width <= 0 || img.height <= 0 || img.rgba.size() != img.pixel_count() * 4) std::abort();
  for (float v : img.rgba)
    if (!std::isfinite(v) || v < 0) std::abort();
  return 0;
}

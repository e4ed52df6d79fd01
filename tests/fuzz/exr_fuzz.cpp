// Fuzz target: any bytes -> io::read_exr_memory (the daemon's upload path). It must never
// crash, leak or hang; every OpenEXR exception must come back as an Error, and a
// successful read must be self-consistent.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "encode/io/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto r = hdrd::io::read_exr_memory({data, size});
  if (!r.ok()) {
    if (r.error().message.empty() || r.error().message.find('\n') != std::string::npos) std::abort();
    return 0;
  }
  const hdrd::Image& img = r->image;
  if (img.width <= 0 || img.height <= 0 || img.rgba.size() != img.pixel_count() * 4) std::abort();
  const hdrd::color::Mat3 m = r->to_working();
  for (const auto& row : m.m)
    for (double v : row)
      if (!std::isfinite(v)) std::abort();
  return 0;
}

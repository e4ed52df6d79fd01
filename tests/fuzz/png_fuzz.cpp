// Fuzz target: any bytes -> io::read_overlay_png_memory and io::read_png_info_memory (UI
// overlays arrive from requests). libpng's longjmp errors must come back as an Error;
// a successful read must be self-consistent.
#include <cstdint>
#include <cstdlib>

#include "encode/io/io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  if (const auto o = hdrd::io::read_overlay_png_memory(bytes); o.ok()) {
    if (o->rgba.size() != static_cast<std::size_t>(o->width) * o->height * 4) std::abort();
    for (float v : o->rgba)
      if (!(v >= 0.0f && v <= 1.0f)) std::abort();
  } else if (o.error().message.empty()) {
    std::abort();
  }
  if (const auto i = hdrd::io::read_png_info_memory(bytes); i.ok()) {
    if (i->samples.size() != static_cast<std::size_t>(i->width) * i->height * i->channels) std::abort();
    if (i->mdcv && i->mdcv->empty()) std::abort();
  }
  return 0;
}

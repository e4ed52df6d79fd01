// Fuzz target: any bytes -> detail::add_item_properties, the ISOBMFF surgery that adds clli
// and mdcv to libavif's output. Malformed boxes must come back as an "avif.container" Error;
// a success must be exactly the input plus the added boxes, and itself a file the function
// accepts again (sizes and offsets consistent).
#include <cstdint>
#include <cstdlib>

#include "encode/io/avif_boxes.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using hdrd::io::detail::add_item_properties;
  using hdrd::io::detail::make_box;
  const std::uint8_t clli[4] = {0x03, 0xE8, 0x01, 0x90};
  const std::vector<std::vector<std::uint8_t>> props{make_box("clli", clli)};
  const auto once = add_item_properties({data, size}, props);
  if (!once.ok()) {
    if (once.error().code != "avif.container" || once.error().message.empty()) std::abort();
    return 0;
  }
  if (once->size() != size + props[0].size() + 1) {
    // + the box, + one ipma association byte (or two with 15-bit indices)
    if (once->size() != size + props[0].size() + 2) std::abort();
  }
  if (!add_item_properties(*once, props).ok()) std::abort();
  return 0;
}

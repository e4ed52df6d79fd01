// Fuzz target for the EDID parser (links only hdrd_edid): truncated blocks, data blocks
// whose lengths overrun their block, absurd extension counts, DisplayID sections that
// lie about their size. Seeds: ../shared/fixtures/edid and tests/fuzz/corpus/edid_fuzz.
#include <cstddef>
#include <cstdint>
#include <span>

#include "display/edid.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto r = hdrd::display::parse_edid(std::span<const std::uint8_t>(data, size));
  if (!r.ok()) return 0;
  // Every field the text formatter touches must be consistent with the parse.
  const std::string text = hdrd::display::format_edid_text(r.value());
  if (text.empty()) __builtin_trap();
  if (r->warnings.size() > 65) __builtin_trap();  // the parser caps its warning list
  return 0;
}

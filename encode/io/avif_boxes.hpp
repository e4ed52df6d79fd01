// Adds item properties to an AVIF (HEIF, ISO/IEC 23008-12) file that libavif wrote.
// libavif 0.11 has no API for `clli` or `mdcv`, and libheif 1.15.1, which has one, aborts
// inside libaom 3.6 on every 10-bit AV1 encode in Debian 12 (heif-enc -b 10 reproduces it),
// so hdrd lets libavif write the file and inserts the two boxes itself.
// Internal to encode/io; fuzzed by tests/fuzz/avif_boxes_fuzz.cpp.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::io::detail {

// One property box, complete (size, type, payload), e.g. make_box("clli", payload).
std::vector<std::uint8_t> make_box(const char (&type)[5], std::span<const std::uint8_t> payload);

// Appends `properties` (complete boxes) to meta/iprp/ipco, associates them (not essential)
// with the primary item in ipma, grows meta/iprp/ipco/ipma by what was added, and moves
// every iloc extent that lies after the insertion point (the mdat) by the same amount.
// Fails with "avif.container" on anything it does not expect (64-bit box sizes, a second
// meta, a missing ipco/ipma/iloc/pitm, offsets that would overflow).
Result<std::vector<std::uint8_t>> add_item_properties(std::span<const std::uint8_t> file,
                                                      const std::vector<std::vector<std::uint8_t>>& properties);

}  // namespace hdrd::io::detail

// Internals shared by the EDID parser's translation units (base block, CTA-861,
// DisplayID). Not part of the public interface.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "display/edid.hpp"

namespace hdrd::display::detail {

using Bytes = std::span<const std::uint8_t>;

// Bounds-checked byte access: reads past the end return 0. Callers check lengths
// first and warn; this is the second line of defence the fuzzer relies on.
inline std::uint8_t at(Bytes b, std::size_t i) { return i < b.size() ? b[i] : 0; }
inline std::uint16_t le16(Bytes b, std::size_t i) {
  return static_cast<std::uint16_t>(at(b, i) | (at(b, i + 1) << 8));
}
inline std::uint32_t le32(Bytes b, std::size_t i) {
  return std::uint32_t(at(b, i)) | (std::uint32_t(at(b, i + 1)) << 8) |
         (std::uint32_t(at(b, i + 2)) << 16) | (std::uint32_t(at(b, i + 3)) << 24);
}
// A sub-span clamped to what exists.
inline Bytes sub(Bytes b, std::size_t offset, std::size_t count) {
  if (offset >= b.size()) return {};
  return b.subspan(offset, std::min(count, b.size() - offset));
}

inline std::uint8_t byte_sum(Bytes b) {
  unsigned s = 0;
  for (auto v : b) s += v;
  return static_cast<std::uint8_t>(s & 0xff);
}

template <class... Args>
void warn(EdidInfo& info, fmt::format_string<Args...> f, Args&&... args) {
  // A hostile blob could produce thousands of complaints; keep the list readable: no
  // exact repeats, and at most 64 entries.
  constexpr std::size_t kMaxWarnings = 64;
  if (info.warnings.size() > kMaxWarnings) return;
  std::string w = fmt::format(f, std::forward<Args>(args)...);
  for (const auto& existing : info.warnings)
    if (existing == w) return;
  if (info.warnings.size() < kMaxWarnings) info.warnings.push_back(std::move(w));
  else info.warnings.push_back("further warnings suppressed");
}

// 18-byte detailed timing descriptor (E-EDID 1.4 §3.10.2, Table 3.21).
DetailedTiming parse_dtd(Bytes d);

// A string from a display descriptor or DisplayID: bytes up to LF (or NUL), at most `max`,
// non-printable bytes replaced by '?'. Sets *nonprintable when it replaced any.
std::string extract_string(Bytes b, std::size_t max, bool* nonprintable);

// A CTA-861 data block collection (CTA-861-G §7.4). `where` names the container for
// warnings and HDR block locations, e.g. "CTA-861 extension (block 1)".
std::vector<CtaDataBlock> parse_cta_data_blocks(Bytes collection, int block_index,
                                                const std::string& where, EdidInfo& info);

void parse_cta_extension(Bytes block, int block_index, EdidInfo& info);
void parse_displayid_extension(Bytes block, int block_index, EdidInfo& info);

std::string oui_string(std::uint32_t oui);  // "00-0C-03"

}  // namespace hdrd::display::detail

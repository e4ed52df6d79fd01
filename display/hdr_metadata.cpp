#include "display/hdr_metadata.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace hdrd::display {
namespace {

// Chromaticity in units of 0.00002 (CTA-861-G §6.9.1: 0xC350 = 1.0), rounded.
std::uint16_t chroma_units(double v) {
  return static_cast<std::uint16_t>(std::clamp(std::lround(v * 50000.0), 0L, 50000L));
}

std::uint16_t clamp_u16(double v) { return static_cast<std::uint16_t>(std::clamp(v, 0.0, 65535.0)); }

bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0; }

void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v & 0xff);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
std::uint16_t get16(std::span<const std::uint8_t> b, std::size_t i) {
  return static_cast<std::uint16_t>(b[i] | (b[i + 1] << 8));
}

}  // namespace

Result<HdrOutputMetadata> make_hdr_output_metadata(Mode mode, const MasteringDisplay& md,
                                                   const ContentLightLevel& light) {
  if (mode != Mode::hdr10 && mode != Mode::hlg)
    return make_error("hdr_metadata.mode",
                      fmt::format("HDR output metadata applies to hdr10 and hlg signals, not {}", to_string(mode)),
                      "display.mode");
  if (!(std::isfinite(md.max_nits) && md.max_nits > 0) || !finite_nonneg(md.min_nits) || md.min_nits >= md.max_nits)
    return make_error("hdr_metadata.mastering",
                      fmt::format("mastering luminance {}..{} cd/m2 is not a valid range", md.min_nits, md.max_nits),
                      "mastering");
  if (!finite_nonneg(light.max_cll_nits) || !finite_nonneg(light.max_fall_nits))
    return make_error("hdr_metadata.content_light", "MaxCLL/MaxFALL must be finite and >= 0", "content_light");
  HdrOutputMetadata m;
  m.eotf = mode == Mode::hdr10 ? InfoframeEotf::smpte_st2084 : InfoframeEotf::hlg;
  const color::Chromaticity prim[3] = {md.primaries.red, md.primaries.green, md.primaries.blue};
  for (int i = 0; i < 3; ++i) m.display_primaries[i] = {chroma_units(prim[i].x), chroma_units(prim[i].y)};
  m.white_point = {chroma_units(md.primaries.white.x), chroma_units(md.primaries.white.y)};
  m.max_display_mastering_luminance = clamp_u16(std::round(md.max_nits));
  m.min_display_mastering_luminance = clamp_u16(std::round(md.min_nits * 10000.0));
  // The values every container carries (encode/frame.hpp: rounded up; 0, CTA-861.3's
  // "unknown", becomes the mastering peak).
  const CarriedLightLevel carried = carried_light_level(light, md);
  m.max_cll = carried.max_cll_nits;
  m.max_fall = carried.max_fall_nits;
  return m;
}

std::array<std::uint8_t, kHdrOutputMetadataSize> serialize(const HdrOutputMetadata& m) {
  std::array<std::uint8_t, kHdrOutputMetadataSize> b{};
  b[0] = static_cast<std::uint8_t>(m.metadata_type & 0xff);
  b[1] = static_cast<std::uint8_t>((m.metadata_type >> 8) & 0xff);
  b[2] = static_cast<std::uint8_t>((m.metadata_type >> 16) & 0xff);
  b[3] = static_cast<std::uint8_t>((m.metadata_type >> 24) & 0xff);
  b[4] = static_cast<std::uint8_t>(m.eotf);
  b[5] = m.infoframe_metadata_type;
  for (int i = 0; i < 3; ++i) {
    put16(&b[6 + 4 * i], m.display_primaries[i][0]);
    put16(&b[8 + 4 * i], m.display_primaries[i][1]);
  }
  put16(&b[18], m.white_point[0]);
  put16(&b[20], m.white_point[1]);
  put16(&b[22], m.max_display_mastering_luminance);
  put16(&b[24], m.min_display_mastering_luminance);
  put16(&b[26], m.max_cll);
  put16(&b[28], m.max_fall);
  return b;  // bytes 30-31: struct padding, zero
}

Result<HdrOutputMetadata> parse_hdr_output_metadata(std::span<const std::uint8_t> b) {
  if (b.size() < 30)
    return make_error("hdr_metadata.size", fmt::format("HDR_OUTPUT_METADATA blob is {} bytes, not 32", b.size()));
  HdrOutputMetadata m;
  m.metadata_type = std::uint32_t(b[0]) | (std::uint32_t(b[1]) << 8) | (std::uint32_t(b[2]) << 16) |
                    (std::uint32_t(b[3]) << 24);
  m.eotf = static_cast<InfoframeEotf>(b[4]);
  m.infoframe_metadata_type = b[5];
  for (int i = 0; i < 3; ++i) m.display_primaries[i] = {get16(b, 6 + 4 * i), get16(b, 8 + 4 * i)};
  m.white_point = {get16(b, 18), get16(b, 20)};
  m.max_display_mastering_luminance = get16(b, 22);
  m.min_display_mastering_luminance = get16(b, 24);
  m.max_cll = get16(b, 26);
  m.max_fall = get16(b, 28);
  return m;
}

ContentLightLevel sequence_light_level(std::span<const ContentLightLevel> frames) {
  ContentLightLevel s;
  for (const auto& f : frames) {
    s.max_cll_nits = std::max(s.max_cll_nits, f.max_cll_nits);
    s.max_fall_nits = std::max(s.max_fall_nits, f.max_fall_nits);
  }
  return s;
}

std::string_view colorspace_name(Mode mode) {
  return (mode == Mode::hdr10 || mode == Mode::hlg) ? "BT2020_RGB" : "Default";
}

}  // namespace hdrd::display

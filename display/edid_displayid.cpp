// DisplayID extension blocks (EDID extension tag 0x70): VESA DisplayID 1.3 and 2.0.
// hdrd decodes what carries HDR capability: the 2.0 Display Parameters block (native
// luminance and chromaticity), the 2.0 Display Interface Features block (colour space /
// EOTF combinations), and CTA-861 data blocks carried in DisplayID (tag 0x81), which is
// where many laptop panels put their HDR Static Metadata.
#include <algorithm>
#include <cmath>

#include "display/edid.hpp"
#include "display/edid_detail.hpp"

namespace hdrd::display {

using detail::at;
using detail::Bytes;
using detail::le16;
using detail::sub;
using detail::warn;

std::string DisplayIdSection::version_string() const {
  return fmt::format("{}.{}", version >> 4, version & 0x0f);
}

std::optional<int> DisplayIdDisplayParameters::color_depth_bpc() const {
  // DisplayID 2.0 §4.2: 000b = 6 bpc ... 101b = 16 bpc; 110b reserved, 111b not defined.
  const int v = depth_and_technology & 7;
  if (v > 5) return std::nullopt;
  return 6 + 2 * v;
}

std::vector<std::string> DisplayIdInterfaceFeatures::combination_names() const {
  static constexpr const char* kNames[7] = {"sRGB", "BT.601", "BT.709/BT.1886", "Adobe RGB",
                                            "DCI-P3", "BT.2020", "BT.2020/SMPTE ST 2084"};
  std::vector<std::string> out;
  for (int i = 0; i < 7; ++i)
    if (combination1 & (1 << i)) out.emplace_back(kNames[i]);
  return out;
}

namespace {

const char* block_name_v2(std::uint8_t tag) {
  switch (tag) {
    case 0x20: return "Product Identification Data Block (0x20)";
    case 0x21: return "Display Parameters Data Block (0x21)";
    case 0x22: return "Video Timing Modes Type 7 - Detailed Timings Data Block";
    case 0x23: return "Video Timing Modes Type 8 - Enumerated Timing Codes Data Block";
    case 0x24: return "Video Timing Modes Type 9 - Formula-based Timings Data Block";
    case 0x25: return "Dynamic Video Timing Range Limits Data Block";
    case 0x26: return "Display Interface Features Data Block";
    case 0x27: return "Stereo Display Interface Data Block (0x27)";
    case 0x28: return "Tiled Display Topology Data Block (0x28)";
    case 0x29: return "ContainerID Data Block";
    case 0x2a: return "Video Timing Modes Type 10 - Formula-based Timings Data Block";
    case 0x2b: return "Adaptive Sync Data Block";
    case 0x7e: return "Vendor-Specific Data Block (0x7e)";
    case 0x81: return "CTA-861 DisplayID Data Block";
    default: return nullptr;
  }
}

const char* block_name_v1(std::uint8_t tag) {
  switch (tag) {
    case 0x00: return "Product Identification Data Block (0x00)";
    case 0x01: return "Display Parameters Data Block (0x01)";
    case 0x02: return "Color Characteristics Data Block";
    case 0x03: return "Video Timing Modes Type 1 - Detailed Timings Data Block";
    case 0x04: return "Video Timing Modes Type 2 - Detailed Timings Data Block";
    case 0x09: return "Video Timing Range Data Block";
    case 0x0c: return "Display Device Data Block";
    case 0x0f: return "Display Interface Data Block";
    case 0x12: return "Tiled Display Topology Data Block (0x12)";
    case 0x7f: return "Vendor-Specific Data Block (0x7f)";
    case 0x81: return "CTA-861 DisplayID Data Block";
    default: return nullptr;
  }
}

// Names whose edid-decode heading line is exactly the name (others add details).
bool heading_is_exact(std::uint8_t tag, bool v2) {
  if (v2) return tag == 0x21 || tag == 0x22 || tag == 0x26 || tag == 0x29 || tag == 0x2b || tag == 0x81;
  return tag == 0x01 || tag == 0x03 || tag == 0x12 || tag == 0x81;
}

color::Chromaticity uv_to_xy(double u, double v) {
  // CIE 1976 u'v' -> CIE 1931 xy (CIE 15:2004 eq. 8.9 inverted).
  const double d = 6 * u - 16 * v + 12;
  return d != 0 ? color::Chromaticity{9 * u / d, 4 * v / d} : color::Chromaticity{};
}

// DisplayID 2.0 §4.2, Table 4-4: 29 bytes of payload.
void parse_parameters_v2(Bytes p, std::uint8_t revision, DisplayIdDataBlock& db, int block_index,
                         const std::string& where, EdidInfo& info) {
  if (p.size() < 29) {
    warn(info, "{}: Display Parameters Data Block: length {} is too short (needs 29)", where, p.size());
    return;
  }
  DisplayIdDisplayParameters d;
  d.block_index = block_index;
  d.size_in_mm = revision & 0x80;
  d.width_raw = le16(p, 0);
  d.height_raw = le16(p, 2);
  d.h_pixels = le16(p, 4);
  d.v_pixels = le16(p, 6);
  d.features = at(p, 8);
  color::Chromaticity* xy[4] = {&d.primaries.red, &d.primaries.green, &d.primaries.blue, &d.primaries.white};
  for (int i = 0; i < 4; ++i) {
    const std::size_t o = 9 + 3 * i;
    const std::uint16_t x = at(p, o) | ((at(p, o + 1) & 0x0f) << 8);
    const std::uint16_t y = (at(p, o + 1) >> 4) | (at(p, o + 2) << 4);
    d.raw_primaries[i] = {x, y};
    *xy[i] = d.cie1976() ? uv_to_xy(x / 4096.0, y / 4096.0) : color::Chromaticity{x / 4096.0, y / 4096.0};
  }
  d.max_full_half = le16(p, 21);
  d.max_10pct_half = le16(p, 23);
  d.min_half = le16(p, 25);
  d.depth_and_technology = at(p, 27);
  if (at(p, 28) != 0xff) d.gamma = (at(p, 28) + 100) / 100.0;
  for (double v : {d.max_full_cd_m2(), d.max_10pct_cd_m2(), d.min_cd_m2()})
    if (!std::isfinite(v) || v < 0)
      warn(info, "{}: Display Parameters Data Block: luminance field is negative, Inf or NaN", where);
  db.parameters = d;
  if (!info.displayid_parameters) info.displayid_parameters = d;
}

// DisplayID 2.0 §4.6, Table 4-17.
void parse_interface_features(Bytes p, DisplayIdDataBlock& db, int block_index, const std::string& where,
                              EdidInfo& info) {
  if (p.size() < 9) {
    warn(info, "{}: Display Interface Features Data Block: length {} is too short (needs 9)", where, p.size());
    return;
  }
  DisplayIdInterfaceFeatures f;
  f.block_index = block_index;
  f.length = static_cast<int>(p.size());
  for (int i = 0; i < 4; ++i) f.bpc_bits[i] = at(p, i);
  f.combination1 = at(p, 6);
  const std::size_t count = at(p, 8);
  if (count > 7) warn(info, "{}: Display Interface Features Data Block: {} additional combinations (max 7)", where, count);
  for (std::size_t i = 0; i < std::min<std::size_t>(count, 7); ++i) {
    if (9 + i >= p.size()) {
      warn(info, "{}: Display Interface Features Data Block: missing additional combinations", where);
      break;
    }
    f.additional.push_back(at(p, 9 + i));
  }
  db.interface = f;
  if (!info.displayid_interface) info.displayid_interface = f;
}

// Product identification: 2.0 §4.1 (OUI) and 1.3 §4.1 (PNP ID); same layout after the ID.
void parse_product_id(Bytes p, bool v2, DisplayIdDataBlock& db, const std::string& where, EdidInfo& info) {
  if (p.size() < 12) {
    warn(info, "{}: Product Identification Data Block: length {} is too short (needs 12)", where, p.size());
    return;
  }
  if (v2) db.oui = (std::uint32_t(at(p, 0)) << 16) | (std::uint32_t(at(p, 1)) << 8) | at(p, 2);
  const std::size_t len = at(p, 11);
  if (12 + len > p.size())
    warn(info, "{}: Product Identification Data Block: product name overruns the block", where);
  bool nonprintable = false;
  std::string name = detail::extract_string(sub(p, 12, len), len, &nonprintable);
  if (nonprintable) warn(info, "{}: Product Identification Data Block: non-printable character", where);
  if (!name.empty()) db.product_name = std::move(name);
}

// DisplayID 1.3 §4.4.1 type I and 2.0 §4.3.1 type VII detailed timings: 20-byte
// descriptors, every field stored minus one; the clock in 10 kHz (type I) or 1 kHz (VII).
void parse_detailed_timings(Bytes p, bool v2, const std::string& where, EdidInfo& info) {
  if (p.size() % 20) warn(info, "{}: detailed timings block length {} is not a multiple of 20", where, p.size());
  for (std::size_t o = 0; o + 20 <= p.size(); o += 20) {
    DetailedTiming t;
    const std::uint32_t clock = (at(p, o) | (at(p, o + 1) << 8) | (std::uint32_t(at(p, o + 2)) << 16)) + 1u;
    t.pixel_clock_khz = v2 ? clock : clock * 10u;
    t.interlaced = at(p, o + 3) & 0x10;
    t.h_active = le16(p, o + 4) + 1;
    t.h_blank = le16(p, o + 6) + 1;
    t.h_front = (le16(p, o + 8) & 0x7fff) + 1;
    t.h_sync = le16(p, o + 10) + 1;
    t.v_active = le16(p, o + 12) + 1;
    t.v_blank = le16(p, o + 14) + 1;
    t.v_front = (le16(p, o + 16) & 0x7fff) + 1;
    t.v_sync = le16(p, o + 18) + 1;
    if ((at(p, o + 3) & 0x80) && !info.displayid_preferred) info.displayid_preferred = info.displayid_timings.size();
    info.displayid_timings.push_back(t);
  }
}

DisplayIdDataBlock parse_data_block(std::uint8_t tag, std::uint8_t rev, Bytes p, bool v2, int block_index,
                                    const std::string& where, EdidInfo& info) {
  DisplayIdDataBlock db;
  db.tag = tag;
  db.revision = rev;
  db.length = static_cast<int>(p.size());
  // Real 1.x sections carry 2.0 blocks (ContainerID, 0x7e) and vice versa: fall back to
  // the other version's table before calling a block unknown.
  const char* own = v2 ? block_name_v2(tag) : block_name_v1(tag);
  const char* other = v2 ? block_name_v1(tag) : block_name_v2(tag);
  const char* name = own ? own : other;
  db.name = name ? name : fmt::format("Unknown DisplayID Data Block (0x{:02x}, length {})", tag, p.size());
  db.name_matches_edid_decode = own ? heading_is_exact(tag, v2) : other ? heading_is_exact(tag, !v2) : true;
  if (v2 && tag == 0x21) parse_parameters_v2(p, rev, db, block_index, where, info);
  else if (v2 && tag == 0x26) parse_interface_features(p, db, block_index, where, info);
  else if ((v2 && tag == 0x20) || (!v2 && tag == 0x00)) parse_product_id(p, v2, db, where, info);
  else if ((v2 && tag == 0x22) || (!v2 && tag == 0x03)) parse_detailed_timings(p, v2, where, info);
  else if (tag == 0x81)
    db.cta = detail::parse_cta_data_blocks(p, block_index, where + ", CTA-861 DisplayID Data Block", info);
  return db;
}

bool all_zero(Bytes b) {
  for (auto v : b)
    if (v) return false;
  return true;
}

}  // namespace

namespace detail {

// DisplayID section inside an EDID extension: byte 0 is the EDID tag 0x70, then version,
// payload length, product type / use case, extension count, data blocks, section checksum.
void parse_displayid_extension(Bytes block, int block_index, EdidInfo& info) {
  DisplayIdSection s;
  s.block_index = block_index;
  s.version = at(block, 1);
  s.product_type = at(block, 3);
  s.extension_count = at(block, 4);
  const std::string where = fmt::format("DisplayID extension (block {})", block_index);
  if (!(s.version >= 0x10 && s.version <= 0x13) && s.version != 0x20 && s.version != 0x21)
    warn(info, "{}: unknown DisplayID version {}", where, s.version_string());
  std::size_t len = at(block, 2);
  if (5 + len + 1 > 127) {
    warn(info, "{}: section length {} overruns the block (max 121)", where, len);
    len = 121;
  }
  s.checksum = at(block, 5 + len);
  if (byte_sum(sub(block, 1, 5 + len)) != 0) warn(info, "{}: DisplayID section checksum mismatch", where);
  const Bytes data = sub(block, 5, len);
  std::size_t j = 0;
  while (j < data.size()) {
    if (all_zero(data.subspan(j))) break;  // padding after the last block
    if (j + 3 > data.size()) {
      warn(info, "{}: {} stray byte(s) at the end of the section", where, data.size() - j);
      break;
    }
    const std::size_t blen = data[j + 2];
    if (j + 3 + blen > data.size()) {
      warn(info, "{}: data block 0x{:02x} (length {}) overruns the section", where, data[j], blen);
      break;
    }
    s.data_blocks.push_back(
        parse_data_block(data[j], data[j + 1], data.subspan(j + 3, blen), s.is_v2(), block_index, where, info));
    j += 3 + blen;
  }
  info.displayid.push_back(std::move(s));
}

}  // namespace detail
}  // namespace hdrd::display

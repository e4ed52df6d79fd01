// EDID base block (VESA E-EDID Standard Release A Rev. 2 = EDID 1.4, and 1.3) and the
// extension-block walk. CTA-861 and DisplayID live in edid_cta.cpp / edid_displayid.cpp.
#include "display/edid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "display/edid_detail.hpp"

namespace hdrd::display {

using detail::at;
using detail::Bytes;
using detail::le16;
using detail::sub;
using detail::warn;

bool EdidChromaticity::all_zero() const {
  for (const RawXy& c : {red, green, blue, white})
    if (c.x || c.y) return false;
  return true;
}

double DetailedTiming::refresh_hz() const {
  const double total = double(h_active + h_blank) * double(v_active + v_blank);
  return total > 0 ? pixel_clock_khz * 1000.0 / total : 0.0;
}

double half_to_double(std::uint16_t h) {
  const int sign = (h >> 15) & 1;
  const int exponent = (h >> 10) & 0x1f;
  const int mantissa = h & 0x3ff;
  double v;
  if (exponent == 0) {
    v = std::ldexp(mantissa, -24);  // subnormal: m * 2^-14 / 1024
  } else if (exponent == 31) {
    v = mantissa ? NAN : INFINITY;
  } else {
    v = std::ldexp(1024 + mantissa, exponent - 25);
  }
  return sign ? -v : v;
}

namespace detail {

DetailedTiming parse_dtd(Bytes d) {
  DetailedTiming t;
  t.pixel_clock_khz = le16(d, 0) * 10u;
  t.h_active = at(d, 2) | ((at(d, 4) & 0xf0) << 4);
  t.h_blank = at(d, 3) | ((at(d, 4) & 0x0f) << 8);
  t.v_active = at(d, 5) | ((at(d, 7) & 0xf0) << 4);
  t.v_blank = at(d, 6) | ((at(d, 7) & 0x0f) << 8);
  t.h_front = at(d, 8) | ((at(d, 11) & 0xc0) << 2);
  t.h_sync = at(d, 9) | ((at(d, 11) & 0x30) << 4);
  t.v_front = (at(d, 10) >> 4) | ((at(d, 11) & 0x0c) << 2);
  t.v_sync = (at(d, 10) & 0x0f) | ((at(d, 11) & 0x03) << 4);
  t.width_mm = at(d, 12) | ((at(d, 14) & 0xf0) << 4);
  t.height_mm = at(d, 13) | ((at(d, 14) & 0x0f) << 8);
  t.interlaced = at(d, 17) & 0x80;
  return t;
}

std::string extract_string(Bytes b, std::size_t max, bool* nonprintable) {
  std::string s;
  for (std::size_t i = 0; i < std::min(max, b.size()); ++i) {
    const std::uint8_t c = b[i];
    if (c == 0x0a || c == 0x00) break;  // LF per the standard; NUL seen in real EDIDs
    if (c < 0x20 || c >= 0x7f) {
      if (nonprintable) *nonprintable = true;
      s.push_back('?');
    } else {
      s.push_back(static_cast<char>(c));
    }
  }
  return s;
}

std::string oui_string(std::uint32_t oui) {
  return fmt::format("{:02X}-{:02X}-{:02X}", (oui >> 16) & 0xff, (oui >> 8) & 0xff, oui & 0xff);
}

}  // namespace detail

namespace {

// PNP ID: three 5-bit letters, 1 = 'A' (E-EDID 1.4 §3.4.1).
std::string parse_manufacturer(Bytes b, EdidInfo& info) {
  const unsigned v = (at(b, 8) << 8) | at(b, 9);
  std::string id;
  bool valid = !(v & 0x8000);
  for (int shift : {10, 5, 0}) {
    const unsigned c = (v >> shift) & 0x1f;
    valid = valid && c >= 1 && c <= 26;
    id.push_back(c >= 1 && c <= 26 ? static_cast<char>('A' + c - 1) : '?');
  }
  if (!valid) warn(info, "Block 0, Base EDID: manufacturer ID 0x{:04x} is not three letters A-Z", v);
  return id;
}

void parse_identification(Bytes b, EdidInfo& info) {
  info.manufacturer = parse_manufacturer(b, info);
  info.product_code = le16(b, 10);
  info.serial_number = detail::le32(b, 12);
  const std::uint8_t week = at(b, 16);
  info.manufacture_year = 1990 + at(b, 17);
  if (week == 0xff) {
    info.model_year = true;
  } else {
    info.manufacture_week = week;
    if (week > 54) warn(info, "Block 0, Base EDID: manufacture week {} is out of range (1-54)", week);
  }
}

void parse_basic_parameters(Bytes b, EdidInfo& info) {
  const std::uint8_t input = at(b, 20);
  info.digital = input & 0x80;
  if (info.digital && info.version == 1 && info.revision >= 4) {
    static constexpr int kDepth[8] = {0, 6, 8, 10, 12, 14, 16, 0};
    static constexpr const char* kInterface[6] = {"", "DVI", "HDMIa", "HDMIb", "MDDI", "DisplayPort"};
    info.bits_per_color = kDepth[(input >> 4) & 7];
    if (((input >> 4) & 7) == 7) warn(info, "Block 0, Base EDID: reserved colour bit depth value 7");
    const int iface = input & 0x0f;
    if (iface < 6) info.interface = kInterface[iface];
    else warn(info, "Block 0, Base EDID: reserved digital interface value {}", iface);
  }
  info.width_cm = at(b, 21);
  info.height_cm = at(b, 22);
  if (at(b, 23) != 0xff) info.gamma = (at(b, 23) + 100) / 100.0;
  info.features = at(b, 24);
}

// Chromaticity: 8 high bits per coordinate in 0x1B-0x22, the 2 low bits packed in
// 0x19 (red, green) and 0x1A (blue, white) (E-EDID 1.4 §3.7, Table 3.12).
void parse_chromaticity(Bytes b, EdidInfo& info) {
  const std::uint8_t lo_rg = at(b, 0x19), lo_bw = at(b, 0x1a);
  auto coord = [&](int hi_offset, std::uint8_t lo, int lo_shift) {
    return static_cast<std::uint16_t>((at(b, hi_offset) << 2) | ((lo >> lo_shift) & 3));
  };
  auto& c = info.chromaticity;
  c.red = {coord(0x1b, lo_rg, 6), coord(0x1c, lo_rg, 4)};
  c.green = {coord(0x1d, lo_rg, 2), coord(0x1e, lo_rg, 0)};
  c.blue = {coord(0x1f, lo_bw, 6), coord(0x20, lo_bw, 4)};
  c.white = {coord(0x21, lo_bw, 2), coord(0x22, lo_bw, 0)};
  if (c.all_zero()) warn(info, "Block 0, Base EDID: colour characteristics are all zero");
}

void parse_display_descriptor(Bytes d, EdidInfo& info) {
  const std::uint8_t tag = at(d, 3);
  if (tag != 0xfc && tag != 0xff && tag != 0xfe) return;
  bool nonprintable = false;
  std::string text = detail::extract_string(sub(d, 5, 13), 13, &nonprintable);
  const char* what = tag == 0xfc ? "Display Product Name" : tag == 0xff ? "Display Product Serial Number"
                                                                       : "Alphanumeric Data String";
  if (nonprintable) warn(info, "Block 0, Base EDID: {}: non-printable character", what);
  info.text_descriptors.push_back({tag, text, !nonprintable});
  if (tag == 0xfc) {
    if (info.name.empty()) info.name = std::move(text);
  } else if (tag == 0xff) {
    if (!info.serial_string) info.serial_string = std::move(text);
  } else {
    info.alphanumeric.push_back(std::move(text));
  }
}

void parse_descriptors(Bytes b, EdidInfo& info) {
  for (int i = 0; i < 4; ++i) {
    const Bytes d = sub(b, 54 + 18 * i, 18);
    if (le16(d, 0) != 0) {
      info.detailed_timings.push_back(detail::parse_dtd(d));
    } else {
      parse_display_descriptor(d, info);
    }
  }
}

void parse_base_block(Bytes b, EdidInfo& info) {
  info.version = at(b, 18);
  info.revision = at(b, 19);
  if (info.version != 1)
    warn(info, "Block 0, Base EDID: EDID structure version {}.{} is not 1.x; parsed as 1.4",
         info.version, info.revision);
  parse_identification(b, info);
  parse_basic_parameters(b, info);
  parse_chromaticity(b, info);
  parse_descriptors(b, info);
  info.extension_count = at(b, 126);
  info.base_checksum = at(b, 127);
  info.base_checksum_ok = detail::byte_sum(b) == 0;
  if (!info.base_checksum_ok)
    warn(info, "Block 0, Base EDID: checksum mismatch (bytes sum to 0x{:02x}, not 0)", detail::byte_sum(b));
}

const char* extension_name(std::uint8_t tag) {
  switch (tag) {
    case 0x02: return "CTA-861 Extension Block";
    case 0x10: return "Video Timing Extension Block";
    case 0x40: return "Display Information Extension Block";
    case 0x50: return "Localized String Extension Block";
    case 0x70: return "DisplayID Extension Block";
    case 0xf0: return "Block Map Extension Block";
    case 0xff: return "Manufacturer-Specific Extension Block";
    default: return nullptr;
  }
}

void parse_extension(Bytes block, int index, EdidInfo& info) {
  ExtensionBlock ext;
  ext.index = index;
  ext.tag = at(block, 0);
  const char* name = extension_name(ext.tag);
  ext.name = name ? name : fmt::format("Unknown EDID Extension Block 0x{:02x}", ext.tag);
  ext.checksum = at(block, 127);
  ext.checksum_ok = detail::byte_sum(block) == 0;
  if (!ext.checksum_ok)
    warn(info, "Block {}, {}: checksum mismatch (bytes sum to 0x{:02x}, not 0)", index, ext.name,
         detail::byte_sum(block));
  info.extensions.push_back(ext);
  if (ext.tag == 0x02) detail::parse_cta_extension(block, index, info);
  else if (ext.tag == 0x70) detail::parse_displayid_extension(block, index, info);
}

// HDMI 2.1 HF-EEODB (HDMI Forum EDID Extension Override Data Block): a data block in the
// first CTA extension (block 1) that overrides byte 0x7E's extension count, so that
// sources which read only 2 blocks still see a valid EDID.
std::optional<int> eeodb_override(const EdidInfo& info) {
  if (info.cta.empty() || info.cta.front().block_index != 1) return std::nullopt;
  for (const auto& db : info.cta.front().data_blocks)
    if (db.eeodb_extension_count) return db.eeodb_extension_count;
  return std::nullopt;
}

void parse_extensions(Bytes bytes, EdidInfo& info) {
  const std::size_t blocks_present = std::min<std::size_t>(bytes.size() / kEdidBlockSize, 256) - 1;
  std::size_t declared = info.extension_count;
  std::size_t i = 1;
  for (; i <= std::min(declared, blocks_present); ++i) {
    parse_extension(sub(bytes, i * kEdidBlockSize, kEdidBlockSize), static_cast<int>(i), info);
    if (i == 1) {
      if (auto n = eeodb_override(info); n && static_cast<std::size_t>(*n) != declared) {
        declared = static_cast<std::size_t>(*n);
        info.extension_count = *n;
      }
    }
  }
  if (declared > blocks_present)
    warn(info, "Base EDID: EDID specified {} extension block(s), but found {} extension block(s)", declared,
         blocks_present);
  else if (blocks_present > declared)
    warn(info, "Base EDID: {} block(s) after the {} declared extension block(s) ignored",
         blocks_present - declared, declared);
}

// DisplayID-only panels name themselves in the Product Identification block.
void name_from_displayid(EdidInfo& info) {
  for (const auto& section : info.displayid)
    for (const auto& db : section.data_blocks)
      if (db.product_name) {
        info.name = *db.product_name;
        return;
      }
}

void check_hdr_sanity(EdidInfo& info) {
  if (info.hdr_static_metadata_blocks > 1)
    warn(info, "{} HDR Static Metadata Data Blocks; the first ({}) is used", info.hdr_static_metadata_blocks,
         info.hdr_static_metadata->location);
  if (!info.hdr_static_metadata) return;
  const auto& h = *info.hdr_static_metadata;
  if ((h.eotf_bits & 0x0f) == 0) warn(info, "HDR Static Metadata Data Block: no EOTF is signalled");
  const auto max = h.max_luminance_cd_m2();
  const auto fall = h.max_frame_avg_luminance_cd_m2();
  if (max && *max > 10000.0)
    warn(info, "HDR Static Metadata Data Block: desired content max luminance {} ({:.3f} cd/m^2) is beyond "
         "the 10000 cd/m^2 that SMPTE ST 2084 can encode", *h.max_luminance_cv, *max);
  if (max && fall && *fall > *max)
    warn(info, "HDR Static Metadata Data Block: max frame-average luminance {:.3f} cd/m^2 exceeds the max "
         "luminance {:.3f} cd/m^2", *fall, *max);
}

}  // namespace

Result<EdidInfo> parse_edid(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kEdidBlockSize)
    return make_error("edid.too_short",
                      fmt::format("EDID is {} bytes; the base block alone is 128", bytes.size()), "edid");
  static constexpr std::uint8_t kHeader[8] = {0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00};
  if (std::memcmp(bytes.data(), kHeader, sizeof kHeader) != 0)
    return make_error("edid.bad_header", "not an EDID: the first 8 bytes are not 00 FF FF FF FF FF FF 00",
                      "edid");
  EdidInfo info;
  info.size_bytes = bytes.size();
  if (bytes.size() % kEdidBlockSize)
    warn(info, "EDID size {} is not a multiple of 128; the last {} byte(s) ignored", bytes.size(),
         bytes.size() % kEdidBlockSize);
  if (bytes.size() > 256 * kEdidBlockSize)
    warn(info, "EDID is {} bytes; only the first 256 blocks are parsed", bytes.size());
  parse_base_block(sub(bytes, 0, kEdidBlockSize), info);
  parse_extensions(bytes, info);
  if (info.name.empty()) name_from_displayid(info);
  if (info.name.empty()) warn(info, "no Display Product Name descriptor");
  check_hdr_sanity(info);
  return info;
}

}  // namespace hdrd::display

// CTA-861 extension block (CTA-861-G §7) and its data block collection; the same
// collection parser serves CTA data blocks carried inside DisplayID (tag 0x81).
#include <algorithm>
#include <cmath>

#include "display/edid.hpp"
#include "display/edid_detail.hpp"

namespace hdrd::display {

using detail::at;
using detail::Bytes;
using detail::sub;
using detail::warn;

double cta_luminance_cd_m2(std::uint8_t cv) { return 50.0 * std::exp2(cv / 32.0); }

double cta_min_luminance_cd_m2(std::uint8_t min_cv, std::uint8_t max_cv) {
  const double r = min_cv / 255.0;
  return cta_luminance_cd_m2(max_cv) * r * r / 100.0;
}

std::optional<double> HdrStaticMetadata::max_luminance_cd_m2() const {
  if (!max_luminance_cv) return std::nullopt;
  return cta_luminance_cd_m2(*max_luminance_cv);
}

std::optional<double> HdrStaticMetadata::max_frame_avg_luminance_cd_m2() const {
  if (!max_frame_avg_luminance_cv) return std::nullopt;
  return cta_luminance_cd_m2(*max_frame_avg_luminance_cv);
}

std::optional<double> HdrStaticMetadata::min_luminance_cd_m2() const {
  if (!min_luminance_cv || !max_luminance_cv) return std::nullopt;
  return cta_min_luminance_cd_m2(*min_luminance_cv, *max_luminance_cv);
}

std::vector<std::string> Colorimetry::names() const {
  // Ascending bit order of bytes 3 and 4, as edid-decode prints them (CTA-861-H Table 78).
  static constexpr const char* kByte3[8] = {"xvYCC601", "xvYCC709", "sYCC601", "opYCC601",
                                            "opRGB", "BT2020cYCC", "BT2020YCC", "BT2020RGB"};
  static constexpr const char* kByte4[8] = {"Reserved MD0", "Reserved MD1", "Reserved MD2", "Reserved MD3",
                                            "Reserved F44", "Reserved F45", "ICtCp", "ST2113RGB"};
  std::vector<std::string> out;
  for (int i = 0; i < 8; ++i)
    if (byte3 & (1 << i)) out.emplace_back(kByte3[i]);
  for (int i = 0; i < 8; ++i)
    if (byte4 & (1 << i)) out.emplace_back(kByte4[i]);
  return out;
}

namespace {

std::uint32_t oui_at(Bytes p, std::size_t i) {
  // OUIs are stored least significant byte first (CTA-861-G §7.5.4).
  return std::uint32_t(at(p, i)) | (std::uint32_t(at(p, i + 1)) << 8) | (std::uint32_t(at(p, i + 2)) << 16);
}

void name_vendor_block(CtaDataBlock& db, const char* kind, std::uint32_t oui) {
  const char* vendor = nullptr;
  switch (oui) {
    case 0x000c03: vendor = "HDMI"; break;
    case 0xc45dd8: vendor = "HDMI Forum"; break;
    case 0x00001a: vendor = "AMD"; break;
    case 0x00d046: vendor = "Dolby"; break;
    case 0x90848b: vendor = "HDR10+"; break;
    default: break;
  }
  db.oui = oui;
  if (vendor) {
    db.name = fmt::format("{} ({}), OUI {}", kind, vendor, detail::oui_string(oui));
  } else {
    db.name = fmt::format("{}, OUI {}", kind, detail::oui_string(oui));
    db.name_matches_edid_decode = false;
  }
}

void parse_colorimetry(Bytes p, CtaDataBlock& db, const std::string& where, EdidInfo& info) {
  if (p.size() < 3) {
    warn(info, "{}: Colorimetry Data Block: length {} is too short (needs 3)", where, p.size());
    return;
  }
  db.colorimetry = Colorimetry{at(p, 1), at(p, 2)};
  if (at(p, 2) & 0x0f) warn(info, "{}: Colorimetry Data Block: reserved bits MD0-MD3 must be 0", where);
  if (!info.colorimetry) info.colorimetry = db.colorimetry;
}

// CTA-861-G §7.5.13: bytes 3 (EOTFs), 4 (descriptors), then optional 5-7 luminance.
void parse_hdr_static(Bytes p, CtaDataBlock& db, int block_index, const std::string& where, EdidInfo& info) {
  if (p.size() < 3) {
    warn(info, "{}: HDR Static Metadata Data Block: length {} is too short (needs 3)", where, p.size());
    return;
  }
  HdrStaticMetadata h;
  h.location = where;
  h.block_index = block_index;
  h.payload_length = static_cast<int>(p.size());
  h.eotf_bits = at(p, 1);
  h.descriptor_bits = at(p, 2);
  if (p.size() > 3) h.max_luminance_cv = at(p, 3);
  if (p.size() > 4) h.max_frame_avg_luminance_cv = at(p, 4);
  if (p.size() > 5) h.min_luminance_cv = at(p, 5);
  if (h.eotf_bits & 0xc0) warn(info, "{}: HDR Static Metadata Data Block: reserved EOTF bits set", where);
  db.hdr_static = h;
  ++info.hdr_static_metadata_blocks;
  if (!info.hdr_static_metadata) info.hdr_static_metadata = std::move(h);
}

void parse_hdr_dynamic(Bytes p, CtaDataBlock& db, const std::string& where, EdidInfo& info) {
  std::size_t j = 1;
  while (j < p.size()) {
    const std::size_t len = at(p, j);
    if (len < 2 || j + 1 + len > p.size()) {
      warn(info, "{}: HDR Dynamic Metadata Data Block: descriptor length {} overruns the block", where, len);
      break;
    }
    const int type = detail::le16(p, j + 1);
    db.hdr_dynamic_types.push_back(type);
    auto& all = info.hdr_dynamic_metadata_types;
    if (std::find(all.begin(), all.end(), type) == all.end()) all.push_back(type);
    j += 1 + len;
  }
}

void parse_vsvdb(Bytes p, CtaDataBlock& db, const std::string& where, EdidInfo& info) {
  if (p.size() < 4) {
    db.name = "Vendor-Specific Video Data Block";
    db.name_matches_edid_decode = false;
    warn(info, "{}: Vendor-Specific Video Data Block: length {} leaves no room for an OUI", where, p.size());
    return;
  }
  name_vendor_block(db, "Vendor-Specific Video Data Block", oui_at(p, 1));
  if (db.oui == 0x90848b) info.hdr10plus_vsvdb = true;
  if (db.oui == 0x00d046) info.dolby_vision_vsvdb = true;
}

const char* extended_name(int ext) {
  switch (ext) {
    case 0x00: return "Video Capability Data Block";
    case 0x05: return "Colorimetry Data Block";
    case 0x06: return "HDR Static Metadata Data Block";
    case 0x07: return "HDR Dynamic Metadata Data Block";
    case 0x0d: return "Video Format Preference Data Block";
    case 0x0e: return "YCbCr 4:2:0 Video Data Block";
    case 0x0f: return "YCbCr 4:2:0 Capability Map Data Block";
    case 0x12: return "Room Configuration Data Block";
    case 0x13: return "Speaker Location Data Block";
    case 0x20: return "InfoFrame Data Block";
    case 0x78: return "HDMI Forum EDID Extension Override Data Block";
    case 0x79: return "HDMI Forum Sink Capability Data Block";
    default: return nullptr;
  }
}

void parse_extended(Bytes p, CtaDataBlock& db, int block_index, const std::string& where, EdidInfo& info) {
  if (p.empty()) {
    db.name = "Empty extended-tag data block";
    db.name_matches_edid_decode = false;
    warn(info, "{}: extended-tag data block with no extended tag byte", where);
    return;
  }
  db.extended_tag = at(p, 0);
  if (const char* n = extended_name(db.extended_tag)) {
    db.name = n;
  } else {
    db.name = fmt::format("Unknown CTA-861 Data Block (extended tag 0x{:02x}, length {})", db.extended_tag,
                          p.size() - 1);
    db.name_matches_edid_decode = false;
  }
  switch (db.extended_tag) {
    case 0x00:
      if (p.size() < 2) {
        warn(info, "{}: Video Capability Data Block: no capability byte", where);
      } else {
        const std::uint8_t v = at(p, 1);
        db.video_capability = VideoCapability{bool(v & 0x80), bool(v & 0x40), std::uint8_t((v >> 4) & 3),
                                              std::uint8_t((v >> 2) & 3), std::uint8_t(v & 3)};
        if (!info.video_capability) info.video_capability = db.video_capability;
      }
      break;
    case 0x01: parse_vsvdb(p, db, where, info); break;
    case 0x05: parse_colorimetry(p, db, where, info); break;
    case 0x06: parse_hdr_static(p, db, block_index, where, info); break;
    case 0x07: parse_hdr_dynamic(p, db, where, info); break;
    case 0x11:
      if (p.size() >= 4) name_vendor_block(db, "Vendor-Specific Audio Data Block", oui_at(p, 1));
      break;
    case 0x78:
      if (p.size() >= 2) db.eeodb_extension_count = at(p, 1);
      break;
    default: break;
  }
}

CtaDataBlock parse_data_block(int tag, Bytes p, int block_index, const std::string& where, EdidInfo& info) {
  CtaDataBlock db;
  db.tag = tag;
  db.length = static_cast<int>(p.size());
  switch (tag) {
    case 1: db.name = "Audio Data Block"; break;
    case 2: db.name = "Video Data Block"; break;
    case 3:
      if (p.size() >= 3) {
        name_vendor_block(db, "Vendor-Specific Data Block", oui_at(p, 0));
      } else {
        db.name = "Vendor-Specific Data Block";
        db.name_matches_edid_decode = false;
        warn(info, "{}: Vendor-Specific Data Block: length {} leaves no room for an OUI", where, p.size());
      }
      break;
    case 4: db.name = "Speaker Allocation Data Block"; break;
    case 5:
      db.name = "VESA Display Transfer Characteristics Data Block";
      db.name_matches_edid_decode = false;
      break;
    case 7: parse_extended(p, db, block_index, where, info); break;
    default:
      db.name = fmt::format("Reserved CTA-861 Data Block (tag {})", tag);
      db.name_matches_edid_decode = false;
      warn(info, "{}: data block with reserved tag {}", where, tag);
      break;
  }
  return db;
}

}  // namespace

namespace detail {

std::vector<CtaDataBlock> parse_cta_data_blocks(Bytes c, int block_index, const std::string& where,
                                                EdidInfo& info) {
  std::vector<CtaDataBlock> blocks;
  std::size_t i = 0;
  while (i < c.size()) {
    if (std::all_of(c.begin() + static_cast<std::ptrdiff_t>(i), c.end(), [](std::uint8_t v) { return v == 0; })) {
      warn(info, "{}: {} byte(s) of zero padding in the data block collection", where, c.size() - i);
      break;
    }
    const int tag = c[i] >> 5;
    const std::size_t len = c[i] & 0x1f;
    if (i + 1 + len > c.size()) {
      warn(info, "{}: data block (tag {}, length {}) overruns the data block collection by {} byte(s)", where, tag,
           len, i + 1 + len - c.size());
      break;
    }
    blocks.push_back(parse_data_block(tag, c.subspan(i + 1, len), block_index, where, info));
    i += 1 + len;
  }
  return blocks;
}

// CTA-861-G §7.3: byte 2 is the offset d of the first DTD; data blocks occupy 4..d-1.
void parse_cta_extension(Bytes block, int block_index, EdidInfo& info) {
  CtaExtension ext;
  ext.block_index = block_index;
  ext.revision = at(block, 1);
  ext.flags = at(block, 3);
  ext.checksum = at(block, 127);
  const std::string where = fmt::format("CTA-861 extension (block {})", block_index);
  if (ext.revision < 1 || ext.revision > 3)
    warn(info, "{}: unknown revision {}; parsed as revision 3", where, ext.revision);
  std::size_t d = at(block, 2);
  if (d != 0 && (d < 4 || d > 127)) {
    warn(info, "{}: detailed timing offset {} is outside 4..127", where, d);
    d = d < 4 ? 4 : 127;
  }
  if (d > 4) {
    if (ext.revision == 1 || ext.revision == 2)
      warn(info, "{}: revision {} has no data block collection, {} byte(s) skipped", where, ext.revision, d - 4);
    else
      ext.data_blocks = parse_cta_data_blocks(sub(block, 4, d - 4), block_index, where, info);
  }
  for (std::size_t off = d ? d : 127; off + 18 <= 127; off += 18) {
    const Bytes dtd = sub(block, off, 18);
    if (detail::le16(dtd, 0) == 0) break;
    ext.detailed_timings.push_back(parse_dtd(dtd));
  }
  info.cta.push_back(std::move(ext));
}

}  // namespace detail
}  // namespace hdrd::display

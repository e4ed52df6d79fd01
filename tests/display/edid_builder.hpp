// Builds synthetic EDIDs byte by byte for parser tests: a valid base block, CTA-861 and
// DisplayID extensions with chosen data blocks, correct checksums unless told otherwise.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hdrd::display::testing {

using Block = std::vector<std::uint8_t>;

inline void fix_checksum(std::uint8_t* block) {
  unsigned sum = 0;
  for (int i = 0; i < 127; ++i) sum += block[i];
  block[127] = static_cast<std::uint8_t>((256 - (sum & 0xff)) & 0xff);
}

// E-EDID 1.4 base block for "ABC" product 0x1234, serial 0x01020304, week 10 of 2020,
// digital 10 bpc DisplayPort, 60x34 cm, gamma 2.2, sRGB-ish chromaticities, one DTD,
// a name descriptor "Test Panel".
inline Block base_block(int extensions) {
  Block b(128, 0);
  const std::uint8_t header[8] = {0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00};
  std::copy(header, header + 8, b.begin());
  // 'A'=1, 'B'=2, 'C'=3: 0 00001 00010 00011 = 0x0443
  b[8] = 0x04; b[9] = 0x43;
  b[10] = 0x34; b[11] = 0x12;
  b[12] = 0x04; b[13] = 0x03; b[14] = 0x02; b[15] = 0x01;
  b[16] = 10; b[17] = 30;
  b[18] = 1; b[19] = 4;
  b[20] = 0x80 | (3 << 4) | 5;  // digital, 10 bpc, DisplayPort
  b[21] = 60; b[22] = 34; b[23] = 120; b[24] = 0x06;
  const std::uint16_t srgb[8] = {655, 338, 307, 614, 154, 61, 320, 337};  // Rec.709 / D65 in 1/1024
  for (int i = 0; i < 8; ++i) b[0x1b + i] = static_cast<std::uint8_t>(srgb[i] >> 2);
  b[0x19] = static_cast<std::uint8_t>(((srgb[0] & 3) << 6) | ((srgb[1] & 3) << 4) | ((srgb[2] & 3) << 2) | (srgb[3] & 3));
  b[0x1a] = static_cast<std::uint8_t>(((srgb[4] & 3) << 6) | ((srgb[5] & 3) << 4) | ((srgb[6] & 3) << 2) | (srgb[7] & 3));
  // 54: a DTD, 1920x1080@60 (148.5 MHz).
  const std::uint8_t dtd[18] = {0x02, 0x3a, 0x80, 0x18, 0x71, 0x38, 0x2d, 0x40, 0x58,
                                0x2c, 0x45, 0x00, 0x56, 0x50, 0x21, 0x00, 0x00, 0x1e};
  std::copy(dtd, dtd + 18, b.begin() + 54);
  // 72: product name descriptor.
  const std::string name = "Test Panel\n  ";
  b[72 + 3] = 0xfc;
  std::copy(name.begin(), name.end(), b.begin() + 72 + 5);
  // 90, 108: dummy descriptors (tag 0x10).
  b[90 + 3] = 0x10;
  b[108 + 3] = 0x10;
  b[126] = static_cast<std::uint8_t>(extensions);
  return b;
}

// Sets the ten chromaticity bytes from 10-bit codes R, G, B, W (x then y each).
inline void set_chromaticity(Block& b, const std::uint16_t c[8]) {
  b[0x19] = static_cast<std::uint8_t>(((c[0] & 3) << 6) | ((c[1] & 3) << 4) | ((c[2] & 3) << 2) | (c[3] & 3));
  b[0x1a] = static_cast<std::uint8_t>(((c[4] & 3) << 6) | ((c[5] & 3) << 4) | ((c[6] & 3) << 2) | (c[7] & 3));
  for (int i = 0; i < 8; ++i) b[0x1b + i] = static_cast<std::uint8_t>(c[i] >> 2);
}

// CTA-861 revision 3 block holding `data_blocks` (each already with its header byte).
inline Block cta_block(const std::vector<Block>& data_blocks) {
  Block b(128, 0);
  b[0] = 0x02;
  b[1] = 3;
  std::size_t at = 4;
  for (const auto& db : data_blocks)
    for (auto v : db) b[at++] = v;
  b[2] = static_cast<std::uint8_t>(at);
  b[3] = 0xc0;
  return b;
}

// Extended-tag CTA data block: header (tag 7, length), extended tag, payload.
inline Block cta_extended(std::uint8_t ext_tag, const Block& payload) {
  Block b;
  b.push_back(static_cast<std::uint8_t>((7 << 5) | (payload.size() + 1)));
  b.push_back(ext_tag);
  for (auto v : payload) b.push_back(v);
  return b;
}

// DisplayID section in an EDID extension block, with correct section checksum.
inline Block displayid_block(std::uint8_t version, const std::vector<Block>& data_blocks, std::uint8_t product_type = 2) {
  Block b(128, 0);
  b[0] = 0x70;
  b[1] = version;
  b[3] = product_type;
  std::size_t at = 5;
  for (const auto& db : data_blocks)
    for (auto v : db) b[at++] = v;
  b[2] = static_cast<std::uint8_t>(at - 5);
  unsigned sum = 0;
  for (std::size_t i = 1; i < at; ++i) sum += b[i];
  b[at] = static_cast<std::uint8_t>((256 - (sum & 0xff)) & 0xff);
  return b;
}

inline std::vector<std::uint8_t> assemble(std::vector<Block> blocks, bool checksums = true) {
  std::vector<std::uint8_t> out;
  for (auto& b : blocks) {
    if (checksums) fix_checksum(b.data());
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

}  // namespace hdrd::display::testing

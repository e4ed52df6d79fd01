#include "encode/video/bitstream.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace hdrd::video {

void BitWriter::put(std::uint64_t value, int bits) {
  for (int i = bits - 1; i >= 0; --i) {
    if (bits_ % 8 == 0) out_.push_back(0);
    if ((value >> i) & 1) out_.back() |= static_cast<std::uint8_t>(0x80u >> (bits_ % 8));
    ++bits_;
  }
}

// ---- HEVC ----------------------------------------------------------------------------------

std::vector<std::uint8_t> sei_mastering_display(const io::St2086Codes& m) {
  BitWriter w;
  for (const auto& xy : {m.green, m.blue, m.red, m.white}) {
    w.put(xy[0], 16);
    w.put(xy[1], 16);
  }
  w.put(m.max_luminance, 32);
  w.put(m.min_luminance, 32);
  return w.bytes();
}

std::vector<std::uint8_t> sei_content_light(const io::Cta861Light& l) {
  BitWriter w;
  w.put(l.max_cll, 16);
  w.put(l.max_fall, 16);
  return w.bytes();
}

namespace {

// payloadType / payloadSize: 0xFF bytes, then the rest (§7.3.5).
void put_sei_number(std::vector<std::uint8_t>& out, std::size_t v) {
  for (; v >= 255; v -= 255) out.push_back(0xFF);
  out.push_back(static_cast<std::uint8_t>(v));
}

// Emulation prevention (§7.4.2): no 00 00 0x (x <= 3) inside a NAL unit.
void append_escaped(std::vector<std::uint8_t>& out, std::span<const std::uint8_t> rbsp) {
  int zeros = 0;
  for (std::uint8_t b : rbsp) {
    if (zeros == 2 && b <= 3) {
      out.push_back(3);
      zeros = 0;
    }
    out.push_back(b);
    zeros = b == 0 ? zeros + 1 : 0;
  }
}

struct NalUnit {
  std::size_t start = 0;  // first byte of its start code (a leading zero_byte included)
  int type = -1;
};

// The NAL units of an Annex B byte stream, in order.
Result<std::vector<NalUnit>> split_annex_b(std::span<const std::uint8_t> s) {
  std::vector<NalUnit> units;
  for (std::size_t i = 0; i + 3 <= s.size(); ++i) {
    if (s[i] != 0 || s[i + 1] != 0 || s[i + 2] != 1) continue;
    const std::size_t start = i > 0 && s[i - 1] == 0 ? i - 1 : i;
    if (i + 3 >= s.size()) return make_error("video.bitstream", "HEVC access unit ends in a start code");
    units.push_back({start, (s[i + 3] >> 1) & 0x3F});
    i += 2;
  }
  if (units.empty() || units.front().start > 1)
    return make_error("video.bitstream", "HEVC access unit does not start with an Annex B start code");
  return units;
}

}  // namespace

std::vector<std::uint8_t> hevc_prefix_sei_nal(std::span<const SeiMessage> messages) {
  std::vector<std::uint8_t> rbsp{39 << 1, 1};  // nal_unit_type 39 (PREFIX_SEI), layer 0, tid 1
  for (const auto& m : messages) {
    put_sei_number(rbsp, static_cast<std::size_t>(m.payload_type));
    put_sei_number(rbsp, m.payload.size());
    rbsp.insert(rbsp.end(), m.payload.begin(), m.payload.end());
  }
  rbsp.push_back(0x80);  // rbsp_trailing_bits
  std::vector<std::uint8_t> nal{0, 0, 0, 1};
  append_escaped(nal, rbsp);
  return nal;
}

Result<std::vector<std::uint8_t>> hevc_insert_before_slices(std::span<const std::uint8_t> au,
                                                            std::span<const std::uint8_t> nal_units) {
  auto units = split_annex_b(au);
  if (!units) return units.error();
  // VCL NAL unit types are 0..31 (Table 7-1).
  const auto vcl = std::find_if(units->begin(), units->end(), [](const NalUnit& u) { return u.type < 32; });
  if (vcl == units->end()) return make_error("video.bitstream", "HEVC access unit has no slice");
  std::vector<std::uint8_t> out;
  out.reserve(au.size() + nal_units.size());
  out.insert(out.end(), au.begin(), au.begin() + static_cast<std::ptrdiff_t>(vcl->start));
  out.insert(out.end(), nal_units.begin(), nal_units.end());
  out.insert(out.end(), au.begin() + static_cast<std::ptrdiff_t>(vcl->start), au.end());
  return out;
}

// ---- AV1 -----------------------------------------------------------------------------------

namespace {

constexpr int kObuFrameHeader = 3, kObuMetadata = 5, kObuFrame = 6;

void put_leb128(std::vector<std::uint8_t>& out, std::uint64_t v) {
  do {
    std::uint8_t b = v & 0x7F;
    v >>= 7;
    if (v) b |= 0x80;
    out.push_back(b);
  } while (v);
}

// leb128() of §4.10.5: at most 8 bytes, the value below 2^32.
Result<std::uint64_t> read_leb128(std::span<const std::uint8_t> s, std::size_t& pos) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) {
    if (pos >= s.size()) return make_error("video.bitstream", "AV1 OBU size runs past the temporal unit");
    const std::uint8_t b = s[pos++];
    v |= static_cast<std::uint64_t>(b & 0x7F) << (7 * i);
    if (!(b & 0x80)) return v <= 0xFFFFFFFFu ? Result<std::uint64_t>(v)
                                              : Result<std::uint64_t>(make_error("video.bitstream", "AV1 OBU size above 2^32"));
  }
  return make_error("video.bitstream", "AV1 leb128 longer than 8 bytes");
}

std::uint32_t fixed_point(double v, double one, double max) {
  return static_cast<std::uint32_t>(std::clamp(std::round(v * one), 0.0, max));
}

}  // namespace

std::vector<std::uint8_t> av1_metadata_obu(int metadata_type, std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> body;
  put_leb128(body, static_cast<std::uint64_t>(metadata_type));
  body.insert(body.end(), payload.begin(), payload.end());
  body.push_back(0x80);  // trailing_bits: the payloads here end on a byte boundary
  std::vector<std::uint8_t> obu{static_cast<std::uint8_t>(kObuMetadata << 3 | 0x02)};  // has_size_field
  put_leb128(obu, body.size());
  obu.insert(obu.end(), body.begin(), body.end());
  return obu;
}

std::vector<std::uint8_t> av1_content_light(const io::Cta861Light& l) { return sei_content_light(l); }

std::vector<std::uint8_t> av1_mastering_display(const MasteringDisplay& m) {
  BitWriter w;
  for (color::Chromaticity c : {m.primaries.red, m.primaries.green, m.primaries.blue, m.primaries.white}) {
    w.put(fixed_point(c.x, 65536, 65535), 16);
    w.put(fixed_point(c.y, 65536, 65535), 16);
  }
  w.put(fixed_point(m.max_nits, 256, 4294967295.0), 32);
  w.put(fixed_point(m.min_nits, 16384, 4294967295.0), 32);
  return w.bytes();
}

Result<std::vector<std::uint8_t>> av1_insert_before_frames(std::span<const std::uint8_t> tu,
                                                           std::span<const std::uint8_t> obus) {
  std::size_t pos = 0;
  while (pos < tu.size()) {
    const std::size_t start = pos;
    const std::uint8_t header = tu[pos++];
    if (header & 0x80) return make_error("video.bitstream", "AV1 OBU with its forbidden bit set");
    const int type = (header >> 3) & 0xF;
    if (header & 0x04) ++pos;  // obu_extension_header
    std::uint64_t size = 0;
    if (header & 0x02) {
      auto s = read_leb128(tu, pos);
      if (!s) return s.error();
      size = *s;
    } else {
      size = pos <= tu.size() ? tu.size() - pos : 0;
    }
    if (pos > tu.size() || size > tu.size() - pos) return make_error("video.bitstream", "AV1 OBU runs past the temporal unit");
    if (type == kObuFrameHeader || type == kObuFrame) {
      std::vector<std::uint8_t> out(tu.begin(), tu.begin() + static_cast<std::ptrdiff_t>(start));
      out.insert(out.end(), obus.begin(), obus.end());
      out.insert(out.end(), tu.begin() + static_cast<std::ptrdiff_t>(start), tu.end());
      return out;
    }
    pos += static_cast<std::size_t>(size);
  }
  return make_error("video.bitstream", "AV1 temporal unit has no frame");
}

}  // namespace hdrd::video

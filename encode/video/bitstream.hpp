// The HDR metadata hdrd writes into video bitstreams itself, and the two insertions that
// put it in place, so every encoder path carries the same numbers whatever the encoder
// library can do (Debian's x265 has no HDR10+, libaom and SVT-AV1 1.4 take no content
// light, and no encoder can know a sequence's MaxCLL before its last frame):
//  - HEVC (ISO/IEC 23008-2 §7.3.2.4, §7.3.5, Annex D): a prefix SEI NAL unit with
//    mastering_display_colour_volume (137), content_light_level_info (144) and
//    user_data_registered_itu_t_t35 (4, HDR10+), inserted into an Annex B access unit
//    before its first slice (after any parameter sets and SEI already there).
//  - AV1 (AV1 spec §5.3, §5.8, §6.7): metadata OBUs METADATA_TYPE_HDR_CLL (1),
//    METADATA_TYPE_HDR_MDCV (2) and METADATA_TYPE_ITUT_T35 (4, HDR10+, as the AOM HDR10+
//    AV1 metadata specification places it), inserted into a temporal unit after its
//    temporal delimiter and sequence header, before the first frame (header) OBU.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "encode/display_target.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/result.hpp"

namespace hdrd::video {

// MSB-first bit writer for bitstream syntax.
class BitWriter {
 public:
  void put(std::uint64_t value, int bits);
  const std::vector<std::uint8_t>& bytes() const { return out_; }  // zero-padded to a byte
  std::size_t bit_count() const { return bits_; }

 private:
  std::vector<std::uint8_t> out_;
  std::size_t bits_ = 0;
};

// ---- HEVC ----------------------------------------------------------------------------------
inline constexpr int kSeiUserDataRegisteredT35 = 4;
inline constexpr int kSeiMasteringDisplayColourVolume = 137;
inline constexpr int kSeiContentLightLevelInfo = 144;

struct SeiMessage {
  int payload_type = 0;
  std::vector<std::uint8_t> payload;  // whole bytes
};
// D.2.28: primaries in the order green, blue, red (ST 2086's), then white, max, min.
std::vector<std::uint8_t> sei_mastering_display(const io::St2086Codes& m);
// D.2.35: max_content_light_level, max_pic_average_light_level.
std::vector<std::uint8_t> sei_content_light(const io::Cta861Light& l);
// A prefix SEI NAL unit (type 39, layer 0, temporal id 0) in Annex B form: a 4-byte start
// code, the header, the messages, rbsp_trailing_bits, emulation prevention bytes.
std::vector<std::uint8_t> hevc_prefix_sei_nal(std::span<const SeiMessage> messages);
// The access unit with `nal_units` (Annex B) placed before its first VCL NAL unit.
Result<std::vector<std::uint8_t>> hevc_insert_before_slices(std::span<const std::uint8_t> access_unit,
                                                            std::span<const std::uint8_t> nal_units);

// ---- AV1 -----------------------------------------------------------------------------------
inline constexpr int kAv1MetadataHdrCll = 1;
inline constexpr int kAv1MetadataHdrMdcv = 2;
inline constexpr int kAv1MetadataItutT35 = 4;

// A metadata OBU with a size field: header, leb128 size, leb128 metadata_type, payload,
// trailing bits.
std::vector<std::uint8_t> av1_metadata_obu(int metadata_type, std::span<const std::uint8_t> payload);
std::vector<std::uint8_t> av1_content_light(const io::Cta861Light& l);
// §6.7.4: chromaticities as 0.16 fixed point in the order red, green, blue, then white;
// luminance_max 24.8 and luminance_min 18.14 fixed point, cd/m2.
std::vector<std::uint8_t> av1_mastering_display(const MasteringDisplay& m);
// The temporal unit (low-overhead OBU format) with `obus` before its first frame OBU.
Result<std::vector<std::uint8_t>> av1_insert_before_frames(std::span<const std::uint8_t> temporal_unit,
                                                           std::span<const std::uint8_t> obus);

}  // namespace hdrd::video

// EDID parser: VESA E-EDID 1.3/1.4 base block, CTA-861 extensions (data block
// collection), DisplayID 1.x/2.x extensions (including CTA data blocks carried inside
// DisplayID and the 2.0 Display Parameters block).
//
// Pure: no libdrm, no I/O. Fatal problems (shorter than one block, bad header) are
// errors; everything else a real display gets wrong (checksums, reserved bits, lengths
// that overrun their block, nonsense luminance) becomes a warning and parsing goes on,
// as libdisplay-info and edid-decode do. Every read is bounds-checked: the parser is
// fuzzed under ASan (tests/fuzz/edid_fuzz.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "encode/colour/color.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

inline constexpr std::size_t kEdidBlockSize = 128;

// IEEE 754 binary16 -> double (DisplayID 2.0 luminance fields).
double half_to_double(std::uint16_t h);

// One 10-bit chromaticity coordinate pair as stored in base block bytes 0x19-0x22
// (E-EDID 1.4 §3.7); value = raw / 1024.
struct RawXy {
  std::uint16_t x = 0, y = 0;
  color::Chromaticity value() const { return {x / 1024.0, y / 1024.0}; }
};

struct EdidChromaticity {
  RawXy red, green, blue, white;
  color::Primaries primaries() const { return {red.value(), green.value(), blue.value(), white.value()}; }
  bool all_zero() const;
};

// 18-byte Detailed Timing Descriptor (E-EDID 1.4 §3.10.2), also DisplayID type I/VII.
struct DetailedTiming {
  std::uint32_t pixel_clock_khz = 0;
  int h_active = 0, h_blank = 0, h_front = 0, h_sync = 0;
  int v_active = 0, v_blank = 0, v_front = 0, v_sync = 0;
  int width_mm = 0, height_mm = 0;
  bool interlaced = false;
  double refresh_hz() const;
};

// CTA-861-G §7.5.13 HDR Static Metadata Data Block. Luminance code values are kept
// as stored; cd/m2 follow the standard's formulas (see *_cd_m2 below).
struct HdrStaticMetadata {
  std::string location;         // e.g. "CTA-861 extension (block 1)"
  int block_index = 0;          // EDID block that carried it
  int payload_length = 0;       // data block length incl. the extended tag (3..7)
  std::uint8_t eotf_bits = 0;   // byte 3: bit0 SDR gamma, bit1 HDR gamma, bit2 ST 2084, bit3 HLG
  std::uint8_t descriptor_bits = 0;  // byte 4: bit0 static metadata type 1
  std::optional<std::uint8_t> max_luminance_cv;
  std::optional<std::uint8_t> max_frame_avg_luminance_cv;
  std::optional<std::uint8_t> min_luminance_cv;

  bool sdr() const { return eotf_bits & 0x01; }
  bool hdr() const { return eotf_bits & 0x02; }
  bool pq() const { return eotf_bits & 0x04; }
  bool hlg() const { return eotf_bits & 0x08; }
  bool static_metadata_type1() const { return descriptor_bits & 0x01; }
  // 50 * 2^(CV/32) (CTA-861-G §7.5.13).
  std::optional<double> max_luminance_cd_m2() const;
  std::optional<double> max_frame_avg_luminance_cd_m2() const;
  // max * (CV/255)^2 / 100, with this block's own max; needs the max byte.
  std::optional<double> min_luminance_cd_m2() const;
};

// Converts a CTA-861 max / frame-average luminance code value to cd/m2.
double cta_luminance_cd_m2(std::uint8_t cv);
double cta_min_luminance_cd_m2(std::uint8_t min_cv, std::uint8_t max_cv);

// CTA-861-H §7.5.5 Colorimetry Data Block (byte 3 and byte 4).
struct Colorimetry {
  std::uint8_t byte3 = 0;  // bit0 xvYCC601 .. bit7 BT2020RGB
  std::uint8_t byte4 = 0;  // bit7 ST2113RGB (DCI-P3 in CTA-861-G), bit6 ICtCp, bits 3-0 MD3..MD0
  bool bt2020_rgb() const { return byte3 & 0x80; }
  bool bt2020_ycc() const { return byte3 & 0x40; }
  bool bt2020_cycc() const { return byte3 & 0x20; }
  bool op_rgb() const { return byte3 & 0x10; }
  bool st2113_rgb() const { return byte4 & 0x80; }
  bool ictcp() const { return byte4 & 0x40; }
  // Names of the set flags, in the order edid-decode prints them.
  std::vector<std::string> names() const;
};

// CTA-861-G §7.5.6 Video Capability Data Block.
struct VideoCapability {
  bool ycc_quantization_selectable = false;  // QY
  bool rgb_quantization_selectable = false;  // QS
  std::uint8_t pt = 0, it = 0, ce = 0;       // scan behaviour fields (2 bits each)
};

// One data block of a CTA-861 data block collection (CTA-861-G §7.4), with the
// payloads hdrd decodes.
struct CtaDataBlock {
  int tag = 0;                // 1..7
  int extended_tag = -1;      // for tag 7
  std::uint32_t oui = 0;      // vendor-specific blocks, as printed (0x000C03 = 00-0C-03)
  int length = 0;             // payload length (after the header byte)
  std::string name;           // as edid-decode names it, e.g. "Colorimetry Data Block"
  bool name_matches_edid_decode = true;  // false for names edid-decode prints differently
  std::optional<Colorimetry> colorimetry;
  std::optional<HdrStaticMetadata> hdr_static;
  std::optional<VideoCapability> video_capability;
  std::vector<int> hdr_dynamic_types;  // HDR Dynamic Metadata Data Block
  std::optional<int> eeodb_extension_count;  // HDMI Forum EDID Extension Override Data Block
};

struct CtaExtension {
  int block_index = 0;
  std::uint8_t revision = 0;
  std::uint8_t flags = 0;     // byte 3: underscan, basic audio, YCbCr 4:4:4 / 4:2:2, native DTDs
  std::uint8_t checksum = 0;
  std::vector<CtaDataBlock> data_blocks;
  std::vector<DetailedTiming> detailed_timings;
};

// DisplayID 2.0 §4.2 Display Parameters Data Block (0x21).
struct DisplayIdDisplayParameters {
  int block_index = 0;
  bool size_in_mm = false;        // revision bit 7: image size in 1 mm instead of 0.1 mm
  int width_raw = 0, height_raw = 0;
  int h_pixels = 0, v_pixels = 0;
  std::uint8_t features = 0;      // scan orientation, luminance info, CIE 1976, audio
  int luminance_info() const { return (features >> 3) & 3; }  // 0 minimum guaranteed, 1 guidance
  bool cie1976() const { return features & 0x40; }
  std::array<std::array<std::uint16_t, 2>, 4> raw_primaries{};  // 12-bit codes / 4096
  color::Primaries primaries;     // CIE 1931 xy (converted from u'v' when cie1976)
  std::uint16_t max_full_half = 0, max_10pct_half = 0, min_half = 0;  // binary16, cd/m2
  double max_full_cd_m2() const { return half_to_double(max_full_half); }
  double max_10pct_cd_m2() const { return half_to_double(max_10pct_half); }
  double min_cd_m2() const { return half_to_double(min_half); }
  std::uint8_t depth_and_technology = 0;
  std::optional<int> color_depth_bpc() const;  // nullopt: not defined
  int device_technology() const { return (depth_and_technology >> 4) & 7; }  // 1 AMLCD, 2 AMOLED
  std::optional<double> gamma;    // native gamma EOTF
};

// DisplayID 2.0 §4.6 Display Interface Features Data Block (0x26), the parts that
// matter for HDR: the supported colour space / EOTF combinations.
struct DisplayIdInterfaceFeatures {
  int block_index = 0;
  int length = 0;
  std::array<std::uint8_t, 4> bpc_bits{};  // RGB, YCbCr 4:4:4, 4:2:2, 4:2:0 depth flags
  std::uint8_t combination1 = 0;           // bit0 sRGB .. bit6 BT.2020/SMPTE ST 2084
  std::vector<std::uint8_t> additional;    // colour space (high nibble) / EOTF (low nibble)
  bool bt2020_pq() const { return combination1 & 0x40; }
  std::vector<std::string> combination_names() const;  // "DCI-P3", "BT.2020/SMPTE ST 2084", ...
};

struct DisplayIdDataBlock {
  std::uint8_t tag = 0;
  std::uint8_t revision = 0;
  int length = 0;
  std::string name;
  bool name_matches_edid_decode = false;
  std::optional<std::uint32_t> oui;
  std::optional<DisplayIdDisplayParameters> parameters;
  std::optional<DisplayIdInterfaceFeatures> interface;
  std::vector<CtaDataBlock> cta;           // 0x81: CTA-861 data blocks carried in DisplayID
  std::optional<std::string> product_name; // product identification block string
};

struct DisplayIdSection {
  int block_index = 0;
  std::uint8_t version = 0;           // 0x12 = 1.2, 0x20 = 2.0
  std::uint8_t product_type = 0;      // 1.x product type / 2.x primary use case
  int extension_count = 0;
  std::uint8_t checksum = 0;
  std::vector<DisplayIdDataBlock> data_blocks;
  bool is_v2() const { return version >= 0x20; }
  std::string version_string() const;
};

struct ExtensionBlock {
  int index = 0;
  std::uint8_t tag = 0;
  std::string name;                   // "CTA-861 Extension Block", "DisplayID Extension Block", ...
  std::uint8_t checksum = 0;
  bool checksum_ok = true;
};

struct EdidInfo {
  std::size_t size_bytes = 0;
  int version = 0, revision = 0;

  // Vendor & product identification (E-EDID 1.4 §3.4).
  std::string manufacturer;           // PNP ID, three letters
  std::uint16_t product_code = 0;
  std::uint32_t serial_number = 0;
  int manufacture_week = 0;           // 0 = unspecified
  int manufacture_year = 0;
  bool model_year = false;            // week byte 0xFF: the year is a model year

  // Basic display parameters (§3.6).
  bool digital = false;
  int bits_per_color = 0;             // 0 = undefined (EDID 1.4 digital only)
  std::string interface;              // "DisplayPort", "HDMIa", ... (EDID 1.4 digital only)
  int width_cm = 0, height_cm = 0;
  std::optional<double> gamma;        // nullopt when 0xFF (defined in an extension)
  std::uint8_t features = 0;
  bool srgb_default() const { return features & 0x04; }

  EdidChromaticity chromaticity;      // §3.7

  // Display descriptors (§3.10.3). Strings keep every byte up to the LF terminator;
  // non-printable bytes become '?' (and a warning), so they are always valid UTF-8.
  std::string name;                   // Display Product Name (0xFC), or DisplayID's
  std::optional<std::string> serial_string;  // 0xFF descriptor
  std::vector<std::string> alphanumeric;     // 0xFE descriptors
  struct TextDescriptor {
    std::uint8_t tag = 0;             // 0xFC name, 0xFF serial, 0xFE alphanumeric
    std::string text;
    bool printable = true;
  };
  std::vector<TextDescriptor> text_descriptors;  // in descriptor order
  std::vector<DetailedTiming> detailed_timings;  // base block DTDs, preferred first
  // DisplayID type I (1.x) / type VII (2.0) detailed timings, and the index of the one
  // flagged preferred (DisplayID-only panels have no base block DTD).
  std::vector<DetailedTiming> displayid_timings;
  std::optional<std::size_t> displayid_preferred;

  int extension_count = 0;            // as declared by byte 0x7E (or HF-EEODB)
  std::uint8_t base_checksum = 0;
  bool base_checksum_ok = true;
  std::vector<ExtensionBlock> extensions;
  std::vector<CtaExtension> cta;
  std::vector<DisplayIdSection> displayid;

  // What matters for HDR, wherever it was found (CTA extension or DisplayID).
  std::optional<HdrStaticMetadata> hdr_static_metadata;  // the first block found
  int hdr_static_metadata_blocks = 0;
  std::optional<Colorimetry> colorimetry;
  std::optional<VideoCapability> video_capability;
  bool hdr10plus_vsvdb = false;       // HDR10+ Vendor-Specific Video Data Block (OUI 90-84-8B)
  bool dolby_vision_vsvdb = false;    // Dolby Vision VSVDB (OUI 00-D0-46)
  std::vector<int> hdr_dynamic_metadata_types;  // CTA-861-H §7.5.14 types (4 = HDR10+)
  std::optional<DisplayIdDisplayParameters> displayid_parameters;  // the first found
  std::optional<DisplayIdInterfaceFeatures> displayid_interface;

  std::vector<std::string> warnings;

  // The base block's first DTD (E-EDID 1.4: the preferred timing), else DisplayID's
  // preferred (or first) detailed timing.
  const DetailedTiming* preferred_timing() const {
    if (!detailed_timings.empty()) return &detailed_timings.front();
    if (displayid_timings.empty()) return nullptr;
    return &displayid_timings[displayid_preferred.value_or(0)];
  }
};

// Parses an EDID blob (128 to 32768 bytes). Errors only when there is nothing to parse:
// fewer than 128 bytes or a bad 8-byte header.
Result<EdidInfo> parse_edid(std::span<const std::uint8_t> bytes);

// The parts of `info` edid-decode also prints, in edid-decode's layout, block by block
// (used by `hdrd edid` and diffed against stored edid-decode output in the tests).
std::string format_edid_text(const EdidInfo& info);

}  // namespace hdrd::display

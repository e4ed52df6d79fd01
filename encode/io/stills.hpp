// HDR stills people can share, from the frame the pipeline encoded: AVIF (libheif 1.15 +
// libaom), JPEG XL (libjxl 0.7) and the gain-map JPEG (libjpeg-turbo; Ultra HDR XMP + MPF
// and ISO 21496-1 metadata). docs/dump-format.md §8-10 describe every byte they carry.
// Writers only: hdrd parses none of these formats.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::io {

// ---- AVIF ---------------------------------------------------------------------------------
// colr nclx = the frame's H.273 code points (hdr10 9/16, hlg 9/18, sdr 1/13, 1/4 or 1/1) with
// the matrix and range below; hdr10/hlg also carry clli (MaxCLL/MaxFALL) and mdcv (ST 2086).
enum class AvifMatrix {
  rgb,    // H.273 MC 0, identity: the planes are G, B, R (what lossless needs)
  ycbcr,  // the container's non-constant-luminance Y'CbCr: MC 9 (BT.2020) or 1 (BT.709)
};
enum class ChromaSubsampling { yuv444, yuv422, yuv420 };

struct AvifOptions {
  int quality = 80;                        // 0..100 (libheif's scale, mapped onto AV1 quantisers); unused when lossless
  bool lossless = false;                   // the decoded samples equal the frame's codes
  int bits = 0;                            // 8, 10 or 12; 0: the frame's (10, or 8 for 8-bit SDR)
  std::optional<Range> range;              // empty: the frame's range
  std::optional<AvifMatrix> matrix;        // empty: rgb when lossless, else ycbcr
  std::optional<ChromaSubsampling> chroma;  // empty: 4:4:4 when lossless or rgb, else 4:2:0
  // libaom speed 0 (slowest) .. 9 (fastest). Empty: 9 when lossless (the samples are the same at
  // every speed; at 4K 9 is 6.5x faster than 7 for 3.7 % more bytes), else 7.
  std::optional<int> speed;
  int threads = 0;                         // 0: all hardware threads (libaom caps at 16)
};
Result<std::vector<std::uint8_t>> encode_avif(const EncodedFrame& frame, const AvifOptions& options = {});
Result<void> write_avif(const std::filesystem::path& path, const EncodedFrame& frame, const AvifOptions& options = {});

// ---- JPEG XL --------------------------------------------------------------------------------
// Colour encoding: Rec.2020 primaries, D65, PQ or HLG transfer (sdr: sRGB, gamma 2.2 or BT.709);
// intensity_target = the target peak in cd/m2, min_nits = the mastering minimum. JPEG XL has
// no narrow range: a narrow frame is written as the full-range signal it stands for.
struct JxlOptions {
  int quality = 90;    // 0..100, mapped to a butteraugli distance as cjxl maps --quality; unused when lossless
  bool lossless = false;  // 16-bit samples equal to the PNG's (8-bit SDR: the 8-bit codes)
  int effort = 3;      // libjxl effort 1 (fastest) .. 9
  int threads = 0;     // 0: all hardware threads
};
Result<std::vector<std::uint8_t>> encode_jxl(const EncodedFrame& frame, const JxlOptions& options = {});
Result<void> write_jxl(const std::filesystem::path& path, const EncodedFrame& frame, const JxlOptions& options = {});

// ---- JPEG: plain SDR, and SDR + gain map -------------------------------------------------
// An 8-bit sRGB JPEG of an SDR frame (sdr mode, 8- or 10-bit; the sRGB or gamma 2.2 curve).
struct JpegOptions {
  int quality = 90;               // libjpeg quality 1..100
  bool subsample_chroma = true;   // 4:2:0 (false: 4:4:4)
};
Result<std::vector<std::uint8_t>> encode_jpeg(const EncodedFrame& sdr, const JpegOptions& options = {});

// How the gain map relates the two renditions (ISO 21496-1 §5; Ultra HDR 1.0 "hdrgm"):
//   gain = (hdr + offset_hdr) / (sdr + offset_sdr), both in linear Rec.709 light relative to
//   SDR white (sdr: the SDR frame's display light / its paper white; hdr: the HDR frame's
//   display light / its paper white, converted to Rec.709 and clipped at 0),
//   map = round(255 * clamp((log2 gain - gain_map_min) / (gain_map_max - gain_map_min), 0, 1)^gamma).
// A display with headroom H (peak / SDR white) shows
//   (sdr + offset_sdr) * 2^(log2 gain * w) - offset_hdr, w = clamp((log2 H - capacity_min) / (capacity_max - capacity_min), 0, 1),
// so capacity_max = log2(HDR peak / HDR paper white) reaches the HDR rendition, and H <= 1 the SDR one.
enum class GainMapChannels {
  rgb,        // one gain per channel (3-channel map): reproduces the HDR rendition's colour too
  luminance,  // one gain from Rec.709 luminance (grey map, smaller): the SDR colour, HDR brightness
};
struct GainMapOptions {
  JpegOptions primary;                  // the SDR rendition
  int gain_map_quality = 85;            // libjpeg quality of the gain map image (always 4:4:4)
  int gain_map_scale = 1;               // the map is ceil(width / scale) x ceil(height / scale), 1..16
  GainMapChannels channels = GainMapChannels::rgb;
  double gamma = 1.0;                   // map gamma, > 0 (ISO 21496-1 gain_map_gamma; hdrgm:Gamma)
  double offset_sdr = 1.0 / 64;         // k_sdr (baseOffset; hdrgm:OffsetSDR), >= 0
  double offset_hdr = 1.0 / 64;         // k_hdr (alternateOffset; hdrgm:OffsetHDR), >= 0
};

// The metadata written, in ISO 21496-1 terms (log2 values; index 0 for a one-channel map).
struct GainMapMetadata {
  int channels = 3;
  std::array<double, 3> gain_map_min_log2{}, gain_map_max_log2{};
  double gamma = 1.0;
  double offset_sdr = 1.0 / 64, offset_hdr = 1.0 / 64;
  double hdr_capacity_min_log2 = 0;  // base headroom: the SDR rendition
  double hdr_capacity_max_log2 = 0;  // alternate headroom: log2(HDR peak / HDR paper white)
};

struct GainMap {
  int width = 0, height = 0, channels = 3;
  std::vector<std::uint8_t> samples;  // width x height x channels map codes, row-major
  GainMapMetadata metadata;
};
// The gain map from an SDR frame (sdr mode) and an HDR frame (hdr10 or hlg) of the same
// size: what the JPEG below carries, for callers that want it on its own.
Result<GainMap> compute_gain_map(const EncodedFrame& sdr, const EncodedFrame& hdr, const GainMapOptions& options = {});

struct GainMapJpeg {
  std::vector<std::uint8_t> bytes;  // the whole file: primary JPEG + gain map JPEG
  std::size_t primary_bytes = 0;    // the primary JPEG's length (the gain map follows it)
  GainMap map;                      // what was encoded (samples before JPEG compression)
};
Result<GainMapJpeg> encode_jpeg_gainmap(const EncodedFrame& sdr, const EncodedFrame& hdr,
                                        const GainMapOptions& options = {});
Result<void> write_jpeg_gainmap(const std::filesystem::path& path, const EncodedFrame& sdr, const EncodedFrame& hdr,
                                const GainMapOptions& options = {});

}  // namespace hdrd::io

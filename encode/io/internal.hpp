// Internal helpers shared by the encode/io/*.cpp files (not part of the public interface).
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <utility>
#include <vector>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::io::detail {

// Bytes per pixel of the DRM formats hdrd produces; 0 for any other fourcc.
int bytes_per_pixel(std::uint32_t drm_fourcc);

// Checks that a frame is self-consistent before it is written: size limits, a DRM
// format that fits the mode, stride >= width * bytes per pixel, data = stride * height
// bytes, and signal16 either empty or width * height * 3 samples.
Result<void> check_frame(const EncodedFrame& frame);

// ---- What every still format says about the signal (one source for PNG, AVIF, JPEG XL) ----

// H.273 code points: hdrd::h273() (the mode table); ST 2086 and content light in a
// carrier's units: encode/io/signal_metadata.hpp (one rule for PNG, AVIF, video, KMS).

// The 10-bit code (XBGR2101010) or 8-bit code (XRGB8888) of pixel (x, y), channel c
// (0 R, 1 G, 2 B). Inline: the writers call it per sample.
inline int code_at(const EncodedFrame& f, int x, int y, int c) {
  const std::uint8_t* p = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4;
  if (f.drm_fourcc == kDrmFormatXrgb8888) return p[2 - c];  // bytes B, G, R, X
  std::uint32_t word;
  std::memcpy(&word, p, 4);  // little-endian host (x86-64, arm64)
  return static_cast<int>((word >> (10 * c)) & 0x3ff);
}

// The 16-bit sample of a 10-bit frame exactly as the PNG stores it (docs/dump-format.md §3).
// Full range: from signal16, round(E' 65535), when the encoder kept it, else
// round(D 65535 / 1023). Narrow: BT.2100 Table 9's 16-bit narrow code round((219 E' + 16) 2^8),
// which for a 10-bit narrow code D is exactly D 2^6; taken from the code so it never depends
// on how signal16 was scaled.
inline std::uint16_t sample16(const EncodedFrame& f, int x, int y, int c) {
  const bool narrow = f.target.range == Range::narrow;
  if (!narrow && !f.signal16.empty()) return f.signal16[(static_cast<std::size_t>(y) * f.width + x) * 3 + c];
  const auto code = static_cast<std::uint32_t>(code_at(f, x, y, c));
  return narrow ? static_cast<std::uint16_t>(code << 6) : static_cast<std::uint16_t>((code * 65535u + 511u) / 1023u);
}

// ---- JPEG (libjpeg-turbo), shared by the SDR and gain-map JPEG writers ----

// 8-bit interleaved samples: 3 components (R, G, B; stored as Y'CbCr) or 1 (grey).
struct JpegSamples {
  int width = 0, height = 0, components = 3;
  std::span<const std::uint8_t> rows;  // height x width x components
};
struct JpegMarker {
  int code = 0;  // 0xE1 APP1, 0xE2 APP2, ...
  std::vector<std::uint8_t> payload;  // at most 65533 bytes
};
// A baseline JFIF JPEG; `markers` follow the JFIF APP0. 4:2:0 when `subsample`, else 4:4:4.
Result<std::vector<std::uint8_t>> compress_jpeg(const JpegSamples& image, int quality, bool subsample,
                                                const std::vector<JpegMarker>& markers = {});

// The SDR frame's 8-bit sRGB samples as its JPEG holds them (sdr mode, srgb curve, full
// range; 10-bit codes rounded to 8 bits).
Result<std::vector<std::uint8_t>> sdr_samples(const EncodedFrame& sdr);

}  // namespace hdrd::io::detail

namespace hdrd::io {
struct GainMap;
struct GainMapOptions;
}  // namespace hdrd::io

namespace hdrd::io::detail {

// compute_gain_map on the SDR frame's samples already taken (sdr_samples).
Result<GainMap> gain_map_of(const EncodedFrame& sdr, std::span<const std::uint8_t> sdr_rgb, const EncodedFrame& hdr,
                            const GainMapOptions& options);

}  // namespace hdrd::io::detail

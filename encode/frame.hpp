// An encoded frame: the DRM-format buffer a display scans out, the PNG samples,
// and the metadata that says exactly what is in it (REFERENCE.md §1.7, §6).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"
#include "encode/image.hpp"

namespace hdrd {

// CTA-861.3 content light level, in cd/m2, as measured from the frame's codes.
struct ContentLightLevel {
  double max_cll_nits = 0;   // largest max(R,G,B) of any pixel, display-referred container signal
  double max_fall_nits = 0;  // largest frame average of per-pixel max(R,G,B)
};

// The one rule for what every container carries as MaxCLL / MaxFALL (CTA-861.3,
// REFERENCE.md §6): whole cd/m2 rounded up, so no container understates the content, but
// never above the mastering maximum rounded down (the encoder caps codes at the peak's, so
// only a fractional peak meets this bound); a value that would be 0 (a black frame) is that
// mastering maximum instead, because
// CTA-861.3 reads 0 as "unknown" and some sinks mishandle it; MaxFALL at most MaxCLL; at
// most 65535 (the InfoFrame's u16). The sidecar's `content_light_level`, the PNG cLLI (these
// values x 10000 in its 0.0001 cd/m2 unit) and the HDR_OUTPUT_METADATA blob all carry exactly
// these numbers (and so should any video stream's SEI).
struct CarriedLightLevel {
  std::uint16_t max_cll_nits = 0;
  std::uint16_t max_fall_nits = 0;
  friend bool operator==(CarriedLightLevel, CarriedLightLevel) = default;
};
CarriedLightLevel carried_light_level(const ContentLightLevel& measured, const MasteringDisplay& mastering);

struct EncodedFrame {
  DisplayTarget target;
  int width = 0;
  int height = 0;

  // The scan-out buffer, little-endian as the DRM format defines it:
  //  hdr10, hlg, 10-bit SDR: XBGR2101010 (R in bits 0-9, G 10-19, B 20-29)
  //  scrgb: ABGR16161616F (R, G, B, A halves in that order)
  //  8-bit SDR: XRGB8888 (bytes B, G, R, X)
  std::uint32_t drm_fourcc = 0;
  std::size_t stride_bytes = 0;
  std::vector<std::uint8_t> data;

  // 16-bit RGB PNG samples, round(E' * 65535) from the signal value (not code << 6),
  // for 10-bit modes; empty for scrgb and 8-bit SDR (whose PNG is the 8-bit codes).
  std::vector<std::uint16_t> signal16;

  // Display-referred linear light in the container primaries, cd/m2, RGBA float.
  // Filled only when asked for (the EXR dump of an encoded frame).
  std::optional<Image> display_nits;

  ContentLightLevel content_light;
  MasteringDisplay mastering;

  // What produced it: tone curve and parameters, exposure, grading, UI, input.
  // Merged into the JSON sidecar.
  nlohmann::json settings = nlohmann::json::object();
};

// The light of a frame's pixels, decoded from its own codes as a display shows them
// (REFERENCE.md §6): hdr10 through the PQ EOTF, hlg through the BT.2100 EOTF at the
// target peak, scrgb as the Rec.2020 signal it would be sent as. Per pixel,
// maxRGB = max(R, G, B, 0) of the Rec.2020 display light in cd/m2. MaxCLL/MaxFALL and the
// per-frame statistics of sequences (HDR10+, Dolby Vision level 1) all read it.
// Empty (pixels == 0) for SDR modes.
struct FrameLight {
  static constexpr int kPqBins = 4096;
  std::array<double, 3> max_channel_nits{};  // largest R, G and B of any pixel (ST 2094-40 maxscl)
  double max_nits = 0;                       // largest maxRGB (the frame's MaxCLL)
  double mean_nits = 0;                      // average maxRGB (its frame-average light level)
  double min_nits = 0;                       // smallest maxRGB
  std::uint64_t pixels = 0;
  // maxRGB distribution: pixels per 12-bit PQ level round(PQ_inv(maxRGB) * 4095). For
  // hdr10 every 10-bit code has a level of its own.
  std::array<std::uint32_t, kPqBins> pq_counts{};
  // The p-th percentile of maxRGB (p in (0, 100]): the PQ level of the ceil(p n / 100)-th
  // smallest pixel, in cd/m2 (within half a 12-bit PQ level); 0 without pixels.
  double percentile_nits(double p) const;
};
// The percentiles the sidecar's frame_light lists (HDR10+'s nine and 99.9).
inline constexpr std::array<double, 10> kFrameLightPercentiles{1, 5, 10, 25, 50, 75, 90, 95, 99, 99.9};
FrameLight measure_frame_light(const EncodedFrame& frame);

// MaxCLL / MaxFALL of one frame: FrameLight's max_nits and mean_nits. Zero for SDR modes.
ContentLightLevel measure_content_light(const EncodedFrame& frame);

}  // namespace hdrd

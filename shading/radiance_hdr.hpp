// Radiance RGBE / XYZE pictures (".hdr", ".pic"): the format of Greg Ward's Radiance
// (Ward 1991, "Real Pixels", Graphics Gems II; the Radiance reference manual's "Picture
// file format"). A bounds-checked reader of our own rather than stb_image's loader:
// Debian 12's stb (2022-09) still has the truncated-RLE endless loop of CVE-2021-42715,
// reads only the "-Y N +X M" orientation, drops EXPOSURE / COLORCORR / PRIMARIES and
// cannot read XYZE; here every layout is read and every failure names what is wrong.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "encode/colour/color.hpp"
#include "encode/image.hpp"
#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::shading {

struct RadianceImage {
  Image image;  // RGBA float, rows top-down as displayed, A = 1; EXPOSURE and COLORCORR divided out
  // The file's PRIMARIES line when it has one. Radiance's own default is its "standard"
  // primaries with an equal-energy white, but the HDR images in circulation are written
  // as linear Rec.709 without saying so; callers assume Rec.709 when this is empty.
  std::optional<color::Primaries> primaries;
  bool xyz = false;        // FORMAT=32-bit_rle_xyze: the channels are CIE X, Y, Z
  double exposure = 1.0;   // product of the EXPOSURE lines (already divided out)
  std::vector<std::string> warnings;
};

// Header, resolution string (all eight orientations), then flat, old-style run-length or
// new-style (per-channel) run-length scanlines. Decoding follows Radiance's colr_color():
// value = (mantissa + 0.5) * 2^(exponent - 136), 0 for exponent 0.
Result<RadianceImage> read_radiance_hdr_memory(std::span<const std::uint8_t> bytes);
Result<RadianceImage> read_radiance_hdr(const std::filesystem::path& path, const io::InputFiles& files = {});

}  // namespace hdrd::shading

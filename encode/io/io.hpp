// Frame I/O: OpenEXR read/write, PNG (16-bit with cICP/mDCV/cLLI for HDR, 8-bit sRGB
// for SDR), raw DRM-format buffers, UI overlay PNGs, JSON sidecars. Every write is
// atomic (temp file in the same directory + rename): a failure leaves no partial file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/colour/color.hpp"
#include "encode/frame.hpp"
#include "encode/image.hpp"
#include "encode/result.hpp"

namespace hdrd::io {

// ---- OpenEXR --------------------------------------------------------------------------
struct ExrImage {
  Image image;  // RGBA float; Y-only and single-channel files are replicated to grey RGB, A = 1
  std::optional<color::Primaries> chromaticities;  // the file's attribute, if any
  bool is_xyz = false;                              // chromaticities are CIE XYZ's own
  std::optional<double> white_luminance;            // cd/m2 of RGB (1,1,1), if present
  std::vector<std::string> channels;                // channel names as stored
  std::string compression;                          // "zip", "piz", ...
  std::map<std::string, std::string> attributes;    // string attributes (hdrd writes its settings there)
  std::vector<std::string> warnings;                // non-fatal oddities (single channel replicated, layer chosen, ...)

  // Matrix from the file's RGB (or XYZ) to linear Rec.2020 D65: Rec.709 when the file
  // says nothing; Bradford for non-D65 RGB; never adapted for XYZ.
  color::Mat3 to_working() const;
};

Result<ExrImage> read_exr(const std::filesystem::path& path);
Result<ExrImage> read_exr_memory(std::span<const std::uint8_t> bytes);
// The pixels the largest part of an EXR declares (its data window), from the header alone:
// what decoding it would allocate, known before anything is decoded.
Result<std::int64_t> exr_declared_pixels(std::span<const std::uint8_t> bytes);

struct ExrWriteOptions {
  bool half = true;  // half or float32 channels
  color::Primaries chromaticities = color::kRec709;
  bool xyz = false;  // write XYZ's own chromaticities instead
  std::optional<double> white_luminance;
  std::map<std::string, std::string> attributes;  // written as string attributes ("hdrd:<key>")
  std::string compression = "zip";               // none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab
};
Result<void> write_exr(const std::filesystem::path& path, const Image& image, const ExrWriteOptions& options);
Result<std::vector<std::uint8_t>> encode_exr(const Image& image, const ExrWriteOptions& options);

// ---- PNG ------------------------------------------------------------------------------
// hdr10/hlg/10-bit SDR: 16-bit RGB with cICP (+ mDCV and cLLI for hdr10/hlg);
// 8-bit SDR: 8-bit RGB with sRGB (or gAMA for gamma 2.2 / BT.1886) chunks.
// scrgb has no PNG form: an error.
Result<std::vector<std::uint8_t>> encode_png(const EncodedFrame& frame);
Result<void> write_png(const std::filesystem::path& path, const EncodedFrame& frame);

// The PNG chunks hdrd writes, read back (for tests and `hdrd inspect`).
struct PngInfo {
  int width = 0, height = 0, bit_depth = 0, color_type = 0;
  std::optional<std::array<std::uint8_t, 4>> cicp;
  std::optional<std::vector<std::uint8_t>> mdcv;  // 24 bytes
  std::optional<std::vector<std::uint8_t>> clli;  // 8 bytes
  std::vector<std::uint16_t> samples;             // decoded samples (8-bit widened), row-major, channels interleaved
  int channels = 0;
};
Result<PngInfo> read_png_info(const std::filesystem::path& path);
Result<PngInfo> read_png_info_memory(std::span<const std::uint8_t> bytes);

// What a PNG declares in its IHDR chunk (PNG spec §11.2.2), read without decoding anything:
// nullopt when the bytes do not start with a PNG signature and an IHDR.
struct PngHeader {
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
};
std::optional<PngHeader> png_header(std::span<const std::uint8_t> bytes);

// The largest image a caller accepts; checked against the declared size before libpng
// allocates or decodes (a 21 KB PNG may declare 16384 x 8192 pixels: 3 GiB as floats).
struct PngLimits {
  std::int64_t max_width = kMaxImageDimension;
  std::int64_t max_height = kMaxImageDimension;
  std::int64_t max_pixels = kMaxImagePixels;
};

// UI overlay: any 8/16-bit PNG (grey, grey+alpha, palette, RGB, RGBA) to RGBA floats in [0,1],
// sRGB-encoded, straight alpha unless `premultiplied` is declared. png.size when the PNG
// declares more than `limits`.
Result<OverlayImage> read_overlay_png(const std::filesystem::path& path, bool premultiplied = false,
                                      const PngLimits& limits = {});
Result<OverlayImage> read_overlay_png_memory(std::span<const std::uint8_t> bytes, bool premultiplied = false,
                                             const PngLimits& limits = {});
// Decoded bytes an overlay of w x h holds at most while it is read (the float image and
// libpng's 16-bit rows), for memory estimates.
std::uint64_t overlay_decode_bytes(std::uint32_t width, std::uint32_t height);

// ---- Raw buffers and sidecars -----------------------------------------------------------
Result<void> write_raw(const std::filesystem::path& path, const EncodedFrame& frame);

// Everything a reader needs to interpret a dump: mode, fourcc, width, height, stride,
// range, bits, peak, black, paper/UI/SDR white, primaries, mastering metadata,
// MaxCLL/MaxFALL, plus frame.settings (tone curve and parameters, exposure, ...), and the
// files written.
nlohmann::json sidecar_json(const EncodedFrame& frame, const std::map<std::string, std::string>& files);

// Writes bytes to `path` atomically.
Result<void> atomic_write(const std::filesystem::path& path, std::span<const std::uint8_t> bytes);

// Whether a file name is one of the temporaries atomic writes create (".NAME.tmp-" and 12
// hex digits) and rename or remove; one left behind belongs to a writer that was killed.
bool is_atomic_write_temporary(std::string_view filename);

enum class DumpFormat { png, exr, raw };
std::optional<DumpFormat> parse_dump_format(std::string_view s);
// The formats that apply to a mode by default: all but png for scrgb.
std::vector<DumpFormat> default_formats(Mode mode);

struct DumpResult {
  std::map<std::string, std::string> files;  // "png" -> path, ..., "sidecar" -> path
};
// A file written with a dump and listed in its sidecar: OUTBASE + suffix, under `kind`
// (e.g. {"scene_exr", ".scene.exr", bytes} for hdrd render's scene-referred frame).
struct ExtraFile {
  std::string kind, suffix;
  std::vector<std::uint8_t> bytes;
};
// Writes OUTBASE.png / OUTBASE.exr / OUTBASE.raw, the extra files and OUTBASE.json (which
// lists them all). Either every file is written or none is left behind. The EXR needs
// frame.display_nits.
Result<DumpResult> write_dumps(const EncodedFrame& frame, const std::filesystem::path& outbase,
                               const std::vector<DumpFormat>& formats, const std::vector<ExtraFile>& extra = {});

}  // namespace hdrd::io

// Frame I/O: OpenEXR read/write, PNG (16-bit with cICP/mDCV/cLLI for HDR, 8-bit sRGB
// for SDR), raw DRM-format buffers, UI overlay PNGs, JSON sidecars. Every write is
// atomic (temp file in the same directory + rename): a failure leaves no partial file.
// WriteOptions::durable adds fsync for files that must survive a power cut.
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
#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::io {

// ---- writing files ----------------------------------------------------------------------
struct WriteOptions {
  // Atomic either way (temp file + rename: a reader or a crash of hdrd never sees a partial
  // file). durable: also fsync each file before its rename and the directory after it, so
  // the new file, not an empty or old one, is there after a power cut; costs the disk's
  // write-back time (docs/dump-format.md "Durable writes").
  bool durable = false;
};

// ---- OpenEXR --------------------------------------------------------------------------
struct ExrImage {
  Image image;  // RGBA float; Y-only and single-channel files are replicated to grey RGB, A = 1
  // The same pixels as half RGBA, instead of `image` (which is then empty), when
  // ExrReadOptions::half_pixels was asked for and every channel read is stored as half.
  ImageHalf half;
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
  bool holds_half() const { return !half.rgba.empty(); }
  int width() const { return holds_half() ? half.width : image.width; }
  int height() const { return holds_half() ? half.height : image.height; }
};

// Non-finite samples of an EXR's R, G and B (alpha is not encoded): NaN and +-Inf counted
// apart. The encoder's rule (docs/encoding.md) makes NaN 0 and +-Inf the largest light,
// which the tone curve takes to the peak; the frame job warns and records the counts.
struct NonFiniteSamples {
  std::uint64_t nan = 0, inf = 0;
  std::uint64_t total() const { return nan + inf; }
};
NonFiniteSamples count_non_finite(const ExrImage& image);

struct ExrReadOptions {
  // Half files decode straight into ExrImage::half (what SceneInput::half takes): no
  // float conversion, half the memory; files with any float or uint channel still give `image`.
  bool half_pixels = false;
};
// `files`: where the path is opened (encode/io/beneath.hpp): beneath a root (the daemon) or
// as given (the CLI); either way a FIFO or other non-regular file is refused, never waited on.
Result<ExrImage> read_exr(const std::filesystem::path& path, const ExrReadOptions& options = {},
                          const InputFiles& files = {});
Result<ExrImage> read_exr_memory(std::span<const std::uint8_t> bytes, const ExrReadOptions& options = {});
// ... naming the bytes `name` in messages (a file already read through InputFiles).
Result<ExrImage> read_exr_memory(std::span<const std::uint8_t> bytes, const ExrReadOptions& options, const std::string& name);
// The pixels the largest part of an EXR declares (its data window), from the header alone:
// what decoding it would allocate, known before anything is decoded.
Result<std::int64_t> exr_declared_pixels(std::span<const std::uint8_t> bytes);
// The largest part's data window size, from the header alone (the same part as above).
struct ExrSize {
  int width = 0, height = 0;
};
Result<ExrSize> exr_declared_size(std::span<const std::uint8_t> bytes, const std::string& name);
// How much of a file's start holds any EXR header the checks above read before a job runs.
inline constexpr std::size_t kExrHeaderPrefixBytes = std::size_t{4} << 20;

struct ExrWriteOptions {
  bool half = true;  // half or float32 channels
  color::Primaries chromaticities = color::kRec709;
  bool xyz = false;  // write XYZ's own chromaticities instead
  std::optional<double> white_luminance;
  std::map<std::string, std::string> attributes;  // written as string attributes ("hdrd:<key>")
  std::string compression = "zip";               // none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab
};
Result<void> write_exr(const std::filesystem::path& path, const Image& image, const ExrWriteOptions& options,
                       const WriteOptions& write = {});
Result<std::vector<std::uint8_t>> encode_exr(const Image& image, const ExrWriteOptions& options);
// Half pixels as they are (options.half must be true): no conversion on the way out.
Result<std::vector<std::uint8_t>> encode_exr(const ImageHalf& image, const ExrWriteOptions& options);
Result<void> write_exr(const std::filesystem::path& path, const ImageHalf& image, const ExrWriteOptions& options,
                       const WriteOptions& write = {});
// RGBA float to half (round to nearest even, overflow to +-Inf, as Imath::half), RGB
// multiplied by rgb_scale first; on `threads` threads (0: every hardware thread).
ImageHalf to_half(const Image& image, float rgb_scale = 1.0f, int threads = 0);

// ---- PNG ------------------------------------------------------------------------------
// hdr10/hlg/10-bit SDR: 16-bit RGB with cICP (+ mDCV and cLLI for hdr10/hlg);
// 8-bit SDR: 8-bit RGB with sRGB (or gAMA for gamma 2.2 / BT.1886) chunks.
// scrgb has no PNG form: an error.
inline constexpr int kMinPngLevel = 0;      // stored: no compression
inline constexpr int kDefaultPngLevel = 1;  // fast: 75-90 % of the raw size for 16-bit photographs
inline constexpr int kMaxPngLevel = 9;      // smallest, several times slower
struct PngOptions {
  // Deflate level: 0 stores; 1-3 fast (ISA-L's igzip levels, the Sub filter); 4-9 smaller
  // and much slower (Paeth filter, zlib's level or ISA-L's best, whichever is smaller).
  // docs/dump-format.md "PNG compression" has the sizes and speeds.
  int level = kDefaultPngLevel;
  int threads = 0;  // 0: every hardware thread; the file is the same for any count
};
Result<void> check_png_options(const PngOptions& options);  // "png.level" / "png.threads" errors
Result<std::vector<std::uint8_t>> encode_png(const EncodedFrame& frame, const PngOptions& options = {});
Result<void> write_png(const std::filesystem::path& path, const EncodedFrame& frame, const PngOptions& options = {},
                       const WriteOptions& write = {});

// The PNG chunks hdrd writes, read back (for tests and `hdrd inspect`).
struct PngInfo {
  int width = 0, height = 0, bit_depth = 0, color_type = 0;
  std::optional<std::array<std::uint8_t, 4>> cicp;
  std::optional<std::vector<std::uint8_t>> mdcv;  // 24 bytes
  std::optional<std::vector<std::uint8_t>> clli;  // 8 bytes
  std::vector<std::uint16_t> samples;             // decoded samples (8-bit widened), row-major, channels interleaved
  int channels = 0;
};
Result<PngInfo> read_png_info(const std::filesystem::path& path, const InputFiles& files = {});
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
                                      const PngLimits& limits = {}, const InputFiles& files = {});
Result<OverlayImage> read_overlay_png_memory(std::span<const std::uint8_t> bytes, bool premultiplied = false,
                                             const PngLimits& limits = {});
// Decoded bytes an overlay of w x h holds at most while it is read (the float image and
// libpng's 16-bit rows), for memory estimates.
std::uint64_t overlay_decode_bytes(std::uint32_t width, std::uint32_t height);

// ---- Raw buffers and sidecars -----------------------------------------------------------
Result<void> write_raw(const std::filesystem::path& path, const EncodedFrame& frame, const WriteOptions& write = {});

// Everything a reader needs to interpret a dump: mode, fourcc, width, height, stride,
// range, bits, peak, black, paper/UI/SDR white, primaries, mastering metadata,
// MaxCLL/MaxFALL, plus frame.settings (tone curve and parameters, exposure, ...), and the
// files written.
nlohmann::json sidecar_json(const EncodedFrame& frame, const std::map<std::string, std::string>& files);

// The error of a failed write of `path` (errno `err`): io.no_space naming the directory
// when its file system is full (ENOSPC, EDQUOT: the operator's to fix; the daemon answers
// 507), else io.write with `what` and the errno's text.
Error write_error(const std::filesystem::path& path, const std::string& what, int err);

// Writes bytes to `path` atomically.
Result<void> atomic_write(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                          const WriteOptions& write = {});
// For writers that stream (video): creates "<dir>/.<name>.tmp-<random>" beside final_path
// with O_EXCL and returns its open descriptor (the caller closes it, and renames the file
// to final_path once it is complete, or removes it).
Result<int> create_temp_file(const std::filesystem::path& final_path, std::filesystem::path& temp);

// Writes a set of files together: each under a temporary name first, then all renamed;
// on any failure none is left behind (renamed ones are removed again).
struct FileToWrite {
  std::filesystem::path path;
  std::span<const std::uint8_t> bytes;
};
Result<void> write_all_or_nothing(const std::vector<FileToWrite>& files, const WriteOptions& write = {});

// The EXR form of an encoded frame (needs frame.display_nits): display light in the
// container primaries, half float, scaled so that value x whiteLuminance = cd/m2 (scRGB:
// nits / 80, whiteLuminance 80; otherwise nits / paper white, whiteLuminance = paper white).
Result<std::vector<std::uint8_t>> encode_display_exr(const EncodedFrame& frame);

// Whether a file name is one of the temporaries atomic writes create (".NAME.tmp-" and 12
// hex digits) and rename or remove; one left behind belongs to a writer that was killed.
bool is_atomic_write_temporary(std::string_view filename);

// A sequence's staging directory, so that its files appear under their final names only
// when it is done (job/sequence.cpp): the per-frame files are written into
// DIR/.STEM.staging-<12 hex digits>/ and, at the end, the journal there names every final
// file the sequence will have before the first is renamed into DIR; the directory is
// removed last. One found at start (sweep_staging) belongs to a sequence that was killed:
// its files and every final-named file its journal names are removed.
Result<std::filesystem::path> make_staging_dir(const std::filesystem::path& outbase);
bool is_staging_dir_name(std::string_view filename);
// Writes the journal (bare file names in the staging directory's parent), then renames each
// `moves` pair (staged path, final path). On a failure the renamed ones are where `moves`
// says: the caller removes them.
Result<void> commit_staged(const std::filesystem::path& staging, const std::vector<std::string>& journal,
                           const std::vector<std::pair<std::filesystem::path, std::filesystem::path>>& moves);
// Removes every staging directory in `dir` and the files their journals name; returns how
// many files it removed.
std::size_t sweep_staging(const std::filesystem::path& dir);

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
struct DumpOptions {
  PngOptions png;
  WriteOptions write;
};
// Writes OUTBASE.png / OUTBASE.exr / OUTBASE.raw, the extra files and OUTBASE.json (which
// lists them all). Either every file is written or none is left behind. The EXR needs
// frame.display_nits.
Result<DumpResult> write_dumps(const EncodedFrame& frame, const std::filesystem::path& outbase,
                               const std::vector<DumpFormat>& formats, const std::vector<ExtraFile>& extra = {},
                               const DumpOptions& options = {});

}  // namespace hdrd::io

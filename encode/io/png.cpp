// PNG write (16-bit RGB with cICP/mDCV/cLLI for HDR and 10-bit SDR, 8-bit RGB for
// 8-bit SDR) and read (hdrd's chunks back, UI overlays of any colour type).
//
// libpng reports errors by longjmp. Every setjmp below sits in a function whose C++
// objects all exist before the setjmp, so a longjmp never skips a destructor.
#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <png.h>

#include "encode/io/io.hpp"
#include "encode/io/internal.hpp"

namespace hdrd::io {
namespace fs = std::filesystem;

namespace {

struct PngErrorState {
  std::string message;
  std::string warnings;  // libpng explains some errors in a warning first ("... exceeds user limit")
  bool truncated = false;
  bool out_of_memory = false;
  PngLimits limits;  // what the reader accepts, for the message
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  if (state && state->message.empty()) state->message = message ? message : "unknown libpng error";
  png_longjmp(png, 1);
}

// Benign oddities (a bad ancillary CRC, ...) are not errors; kept to explain an error.
void on_png_warning(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  if (state && message && state->warnings.size() < 512) state->warnings.append(message).append("; ");
}

// ---- chunk payloads (PNG 3rd edition §11.3.2.6-8, all big-endian) ----------------------

void put_u16(std::vector<std::uint8_t>& v, std::uint32_t x) {
  v.push_back(static_cast<std::uint8_t>(x >> 8));
  v.push_back(static_cast<std::uint8_t>(x));
}
void put_u32(std::vector<std::uint8_t>& v, std::uint32_t x) {
  put_u16(v, x >> 16);
  put_u16(v, x & 0xffff);
}

std::uint32_t to_units(double value, double unit, double max, bool round_up) {
  if (!(value > 0)) return 0;  // also NaN
  const double units = value / unit;
  // Round up so the container never states less than was measured (REFERENCE.md §6);
  // the small slack keeps exact values such as 123.45 cd/m2 from rounding to the next unit.
  const double r = round_up ? std::ceil(units - 1e-6) : std::round(units);
  return static_cast<std::uint32_t>(std::min(r, max));
}

// H.273 code points. SDR: 13 = IEC 61966-2-1 sRGB; 4 = BT.470 System M, "assumed display
// gamma 2.2"; 1 = BT.709, whose reference display EOTF is BT.1886 (H.273 Table 3 note).
std::array<std::uint8_t, 4> cicp_for(const DisplayTarget& t) {
  std::uint8_t primaries = 1, transfer = 13;
  switch (t.mode) {
    case Mode::hdr10: primaries = 9; transfer = 16; break;
    case Mode::hlg: primaries = 9; transfer = 18; break;
    case Mode::sdr: transfer = t.sdr_curve == SdrCurve::srgb ? 13 : 4; break;
    case Mode::sdr_bt1886: transfer = 1; break;
    case Mode::scrgb: break;  // no PNG form; rejected before this
  }
  return {primaries, transfer, 0, static_cast<std::uint8_t>(t.range == Range::full ? 1 : 0)};
}

// mDCV: R, G, B and white x,y as u16 in 0.00002, then max and min luminance as u32 in 0.0001 cd/m2.
std::vector<std::uint8_t> mdcv_for(const MasteringDisplay& m) {
  std::vector<std::uint8_t> v;
  for (color::Chromaticity c : {m.primaries.red, m.primaries.green, m.primaries.blue, m.primaries.white}) {
    put_u16(v, to_units(c.x, 0.00002, 65535, false));
    put_u16(v, to_units(c.y, 0.00002, 65535, false));
  }
  put_u32(v, to_units(m.max_nits, 0.0001, 4294967295.0, false));
  put_u32(v, to_units(m.min_nits, 0.0001, 4294967295.0, false));
  return v;
}

// cLLI: MaxCLL, MaxFALL as u32 in 0.0001 cd/m2, rounded up. 0 means "unknown" and some
// displays misbehave on it, so a value that would be 0 becomes the mastering peak
// (REFERENCE.md §6), as in the KMS metadata blob (display/hdr_metadata.cpp).
std::vector<std::uint8_t> clli_for(const ContentLightLevel& l, const MasteringDisplay& m) {
  std::vector<std::uint8_t> v;
  auto carried = [&](double nits) {
    const auto units = to_units(nits, 0.0001, 4294967295.0, true);
    return units != 0 ? units : to_units(m.max_nits, 0.0001, 4294967295.0, true);
  };
  put_u32(v, carried(l.max_cll_nits));
  put_u32(v, carried(l.max_fall_nits));
  return v;
}

// ---- rows -------------------------------------------------------------------------------

struct RowSource {
  const EncodedFrame* frame = nullptr;
  bool sixteen = false;
  bool narrow = false;

  void fill(int y, std::uint8_t* row) const {
    const auto& f = *frame;
    const std::uint8_t* src = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    for (int x = 0; x < f.width; ++x) {
      if (!sixteen) {  // XRGB8888 bytes B, G, R, X
        row[x * 3 + 0] = src[x * 4 + 2];
        row[x * 3 + 1] = src[x * 4 + 1];
        row[x * 3 + 2] = src[x * 4 + 0];
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const std::uint16_t s = sample16(src, y, x, c);
        row[x * 6 + c * 2] = static_cast<std::uint8_t>(s >> 8);
        row[x * 6 + c * 2 + 1] = static_cast<std::uint8_t>(s);
      }
    }
  }

  // Full range: round(E' * 65535) from signal16 when the encoder kept it, else from the
  // 10-bit code as round(D * 65535 / 1023). Narrow range: the 16-bit narrow code of
  // BT.2100 Table 9, round((219 E' + 16) * 2^8), which for a 10-bit narrow code D is
  // exactly D * 2^6; taken from the code so it never depends on how signal16 was scaled.
  std::uint16_t sample16(const std::uint8_t* src, int y, int x, int c) const {
    const auto& f = *frame;
    if (!narrow && !f.signal16.empty()) return f.signal16[(static_cast<std::size_t>(y) * f.width + x) * 3 + c];
    std::uint32_t word;
    std::memcpy(&word, src + x * 4, 4);  // little-endian host (x86-64, arm64)
    const std::uint32_t code = (word >> (10 * c)) & 0x3ff;
    return narrow ? static_cast<std::uint16_t>(code << 6)
                  : static_cast<std::uint16_t>((code * 65535u + 511u) / 1023u);
  }
};

struct PngWriteJob {
  int width = 0, height = 0, bit_depth = 8;
  RowSource rows;
  std::array<std::uint8_t, 4> cicp{};
  std::vector<std::uint8_t> mdcv, clli;  // empty = not written
  enum class Legacy { none, srgb, gamma22, bt1886 } legacy = Legacy::none;
  std::vector<std::uint8_t> row;
  std::vector<std::uint8_t> out;
  PngErrorState error;
};

void append_bytes(png_structp png, png_bytep data, std::size_t n) {
  auto* job = static_cast<PngWriteJob*>(png_get_io_ptr(png));
  bool failed = false;
  try {
    job->out.insert(job->out.end(), data, data + n);
  } catch (...) {
    failed = true;
  }
  if (failed) png_error(png, "out of memory");
}

void set_unknown_chunks(png_structp png, png_infop info, PngWriteJob& job) {
  png_unknown_chunk chunks[3]{};
  int n = 0;
  const auto add = [&](const char* name, std::uint8_t* data, std::size_t size) {
    std::memcpy(chunks[n].name, name, 5);
    chunks[n].data = data;
    chunks[n].size = size;
    chunks[n].location = PNG_HAVE_IHDR;
    ++n;
  };
  add("cICP", job.cicp.data(), job.cicp.size());
  if (!job.mdcv.empty()) add("mDCV", job.mdcv.data(), job.mdcv.size());
  if (!job.clli.empty()) add("cLLI", job.clli.data(), job.clli.size());
  // Without ALWAYS libpng silently drops these (their 4th letter is upper case: not
  // safe-to-copy); platform-debian12.md §6.
  png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_ALWAYS,
                              reinterpret_cast<png_const_bytep>("cICP\0mDCV\0cLLI\0"), 3);
  png_set_unknown_chunks(png, info, chunks, n);
  for (int i = 0; i < n; ++i) png_set_unknown_chunk_location(png, info, i, PNG_HAVE_IHDR);
}

void set_legacy_colour(png_structp png, png_infop info, PngWriteJob::Legacy legacy) {
  using L = PngWriteJob::Legacy;
  if (legacy == L::none) return;
  if (legacy == L::srgb) {
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    return;
  }
  // gAMA holds the encoding exponent x 100000: 1/2.2 -> 45455, 1/2.4 -> 41667.
  png_set_gAMA_fixed(png, info, legacy == L::gamma22 ? 45455 : 41667);
  png_set_cHRM_fixed(png, info, 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000);
}

bool run_png_write(PngWriteJob& job) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &job.error, on_png_error, on_png_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &job, append_bytes, nullptr);
  // platform-debian12.md §6: zlib level 1 + the Up filter is ~7x faster than the defaults.
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_set_IHDR(png, info, static_cast<png_uint_32>(job.width), static_cast<png_uint_32>(job.height),
               job.bit_depth, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE,
               PNG_FILTER_TYPE_BASE);
  set_legacy_colour(png, info, job.legacy);
  set_unknown_chunks(png, info, job);
  png_write_info(png, info);
  for (int y = 0; y < job.height; ++y) {
    job.rows.fill(y, job.row.data());
    png_write_row(png, job.row.data());
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_png(const EncodedFrame& frame) {
  if (frame.target.mode == Mode::scrgb)
    return make_error("png.unsupported", "scrgb has no PNG form (PNG cannot hold FP16 scRGB); use exr or raw",
                      "format");
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  PngWriteJob job;
  job.width = frame.width;
  job.height = frame.height;
  job.rows.frame = &frame;
  job.rows.sixteen = frame.drm_fourcc != kDrmFormatXrgb8888;
  job.rows.narrow = frame.target.range == Range::narrow;
  job.bit_depth = job.rows.sixteen ? 16 : 8;
  job.cicp = cicp_for(frame.target);
  const Mode mode = frame.target.mode;
  if (mode == Mode::hdr10 || mode == Mode::hlg) {
    job.mdcv = mdcv_for(frame.mastering);
    job.clli = clli_for(frame.content_light, frame.mastering);
  } else if (mode == Mode::sdr) {
    job.legacy = frame.target.sdr_curve == SdrCurve::srgb ? PngWriteJob::Legacy::srgb : PngWriteJob::Legacy::gamma22;
  } else {
    job.legacy = PngWriteJob::Legacy::bt1886;
  }
  job.row.resize(static_cast<std::size_t>(frame.width) * 3 * (job.bit_depth / 8));
  job.out.reserve(static_cast<std::size_t>(frame.width) * frame.height * (job.bit_depth / 8) * 3 / 2);
  if (!run_png_write(job))
    return make_error("png.write", fmt::format("cannot encode PNG: {}",
                                               job.error.message.empty() ? "libpng failed" : job.error.message));
  return std::move(job.out);
}

Result<void> write_png(const fs::path& path, const EncodedFrame& frame) {
  auto bytes = encode_png(frame);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes);
}

// ---- reading ----------------------------------------------------------------------------

namespace {

struct PngReadJob {
  std::span<const std::uint8_t> bytes;
  std::size_t pos = 0;
  bool overlay = false;  // expand to RGBA for a UI overlay
  PngLimits limits;
  PngErrorState error;
  // after the header
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
  int out_channels = 0, out_depth = 0;
  std::size_t rowbytes = 0;
  // after the pixels
  std::vector<std::uint8_t> pixels;
  std::vector<png_bytep> rows;
};

void read_bytes(png_structp png, png_bytep out, std::size_t n) {
  auto* job = static_cast<PngReadJob*>(png_get_io_ptr(png));
  if (n > job->bytes.size() - job->pos) {
    job->error.truncated = true;
    png_error(png, "unexpected end of data");
  }
  std::memcpy(out, job->bytes.data() + job->pos, n);
  job->pos += n;
}

bool read_header(png_structp png, png_infop info, PngReadJob& job) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_read_fn(png, &job, read_bytes);
  // Size limits before libpng allocates anything for the image (image.hpp limits).
  png_set_user_limits(png, png_uint_32(std::min<std::int64_t>(job.limits.max_width, kMaxImageDimension)),
                      png_uint_32(std::min<std::int64_t>(job.limits.max_height, kMaxImageDimension)));
  png_set_chunk_malloc_max(png, 8u << 20);
  png_set_chunk_cache_max(png, 64);
  png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_ALWAYS,
                              reinterpret_cast<png_const_bytep>("cICP\0mDCV\0cLLI\0"), 3);
  png_read_info(png, info);
  png_get_IHDR(png, info, &job.width, &job.height, &job.bit_depth, &job.color_type, nullptr, nullptr, nullptr);
  png_set_expand(png);  // palette -> RGB, grey < 8 bits -> 8, tRNS -> alpha
  if (job.overlay) {
    png_set_gray_to_rgb(png);
    if (!(job.color_type & PNG_COLOR_MASK_ALPHA) && !png_get_valid(png, info, PNG_INFO_tRNS))
      png_set_add_alpha(png, 0xffff, PNG_FILLER_AFTER);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  job.out_channels = png_get_channels(png, info);
  job.out_depth = png_get_bit_depth(png, info);
  job.rowbytes = png_get_rowbytes(png, info);
  return true;
}

bool read_pixels(png_structp png, png_infop info, PngReadJob& job) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, job.rows.data());
  png_read_end(png, nullptr);  // reads to IEND: a file cut after its image data is truncated
  return true;
}

Error png_read_error(const std::string& name, const PngErrorState& e) {
  if (e.truncated) return make_error("png.truncated", fmt::format("cannot read PNG {}: truncated file", name));
  if (e.message.find("exceeds user limit") != std::string::npos ||
      e.warnings.find("exceeds user limit") != std::string::npos)
    return make_error("png.size", fmt::format("cannot read PNG {}: image larger than {}x{} pixels", name,
                                              e.limits.max_width, e.limits.max_height));
  return make_error("png.corrupt", fmt::format("cannot read PNG {}: corrupt file ({})", name,
                                               e.message.empty() ? "libpng failed" : e.message));
}

struct ReadStructs {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~ReadStructs() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
};

// Decodes the whole image into job.pixels (big-endian 16-bit samples when out_depth is 16).
Result<void> decode(PngReadJob& job, const std::string& name, PngInfo* chunks_out) {
  if (job.bytes.size() < 8 || png_sig_cmp(job.bytes.data(), 0, 8) != 0)
    return make_error("png.not_png", fmt::format("cannot read PNG {}: not a PNG file (bad signature)", name));
  job.error.limits = job.limits;
  // The declared size first, before libpng allocates or inflates anything.
  if (const auto h = png_header(job.bytes)) {
    const std::int64_t w = h->width, ht = h->height;
    if (w > job.limits.max_width || ht > job.limits.max_height || w * ht > job.limits.max_pixels)
      return make_error("png.size", fmt::format("cannot read PNG {}: it declares {}x{} pixels, at most {}x{} and {} "
                                                "pixels are accepted", name, w, ht, job.limits.max_width,
                                                job.limits.max_height, job.limits.max_pixels));
  }
  ReadStructs s;
  s.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &job.error, on_png_error, on_png_warning);
  if (!s.png) return make_error("png.corrupt", "cannot create a libpng reader");
  s.info = png_create_info_struct(s.png);
  if (!s.info) return make_error("png.corrupt", "cannot create a libpng reader");
  if (!read_header(s.png, s.info, job)) return png_read_error(name, job.error);
  if (auto size = check_image_size(job.width, job.height); !size)
    return make_error("png.size", fmt::format("cannot read PNG {}: {}", name, size.error().message));
  if (chunks_out) {
    png_unknown_chunkp unknown = nullptr;
    const int n = png_get_unknown_chunks(s.png, s.info, &unknown);
    for (int i = 0; i < n; ++i) {
      const std::string chunk(reinterpret_cast<const char*>(unknown[i].name), 4);
      std::vector<std::uint8_t> data(unknown[i].data, unknown[i].data + unknown[i].size);
      if (chunk == "cICP" && data.size() == 4) chunks_out->cicp = std::array<std::uint8_t, 4>{data[0], data[1], data[2], data[3]};
      else if (chunk == "mDCV") chunks_out->mdcv = std::move(data);
      else if (chunk == "cLLI") chunks_out->clli = std::move(data);
    }
  }
  job.pixels.resize(job.rowbytes * job.height);
  job.rows.resize(job.height);
  for (png_uint_32 y = 0; y < job.height; ++y) job.rows[y] = job.pixels.data() + job.rowbytes * y;
  if (!read_pixels(s.png, s.info, job)) return png_read_error(name, job.error);
  return {};
}

std::uint16_t sample_at(const PngReadJob& job, std::size_t i) {
  if (job.out_depth == 16) return static_cast<std::uint16_t>((job.pixels[2 * i] << 8) | job.pixels[2 * i + 1]);
  return job.pixels[i];
}

Result<std::vector<std::uint8_t>> slurp(const fs::path& path, const char* what, const char* code_prefix) {
  const std::string name = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec))
    return make_error(std::string(code_prefix) + ".missing", fmt::format("cannot read {} {}: no such file", what, name));
  const auto size = fs::file_size(path, ec);
  if (ec || fs::is_directory(path, ec))
    return make_error(std::string(code_prefix) + ".unreadable", fmt::format("cannot read {} {}: not a regular file", what, name));
  if (size > (std::uintmax_t{1} << 31))
    return make_error(std::string(code_prefix) + ".size", fmt::format("cannot read {} {}: file larger than 2 GiB", what, name));
  std::ifstream f(path, std::ios::binary);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  if (!f || !f.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    return make_error(std::string(code_prefix) + ".unreadable", fmt::format("cannot read {} {}: read failed", what, name));
  return bytes;
}

Result<PngInfo> read_png_info_named(std::span<const std::uint8_t> bytes, const std::string& name) {
  PngReadJob job;
  job.bytes = bytes;
  PngInfo info;
  if (auto ok = decode(job, name, &info); !ok) return ok.error();
  info.width = static_cast<int>(job.width);
  info.height = static_cast<int>(job.height);
  info.bit_depth = job.bit_depth;
  info.color_type = job.color_type;
  info.channels = job.out_channels;
  const std::size_t row_samples = static_cast<std::size_t>(job.width) * job.out_channels;
  info.samples.resize(row_samples * job.height);
  for (std::size_t y = 0; y < job.height; ++y)
    for (std::size_t i = 0; i < row_samples; ++i)
      info.samples[y * row_samples + i] = sample_at(job, y * job.rowbytes / (job.out_depth / 8) + i);
  return info;
}

Result<OverlayImage> read_overlay_named(std::span<const std::uint8_t> bytes, const std::string& name,
                                        bool premultiplied, const PngLimits& limits) {
  PngReadJob job;
  job.bytes = bytes;
  job.overlay = true;
  job.limits = limits;
  if (auto ok = decode(job, name, nullptr); !ok) return ok.error();
  OverlayImage img;
  img.width = static_cast<int>(job.width);
  img.height = static_cast<int>(job.height);
  img.premultiplied = premultiplied;
  const float scale = job.out_depth == 16 ? 1.0f / 65535.0f : 1.0f / 255.0f;
  const std::size_t row_samples = static_cast<std::size_t>(job.width) * 4;
  img.rgba.resize(row_samples * job.height);
  for (std::size_t y = 0; y < job.height; ++y)
    for (std::size_t i = 0; i < row_samples; ++i)
      img.rgba[y * row_samples + i] = sample_at(job, y * job.rowbytes / (job.out_depth / 8) + i) * scale;
  return img;
}

}  // namespace

Result<PngInfo> read_png_info(const fs::path& path) {
  auto bytes = slurp(path, "PNG", "png");
  if (!bytes) return bytes.error();
  return read_png_info_named(*bytes, path.string());
}

Result<PngInfo> read_png_info_memory(std::span<const std::uint8_t> bytes) {
  return read_png_info_named(bytes, "<memory>");
}

std::optional<PngHeader> png_header(std::span<const std::uint8_t> bytes) {
  // Signature (8), IHDR length (4) = 13, "IHDR", width, height, bit depth, colour type.
  static const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 26 || std::memcmp(bytes.data(), kSignature, 8) != 0 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0)
    return std::nullopt;
  const auto be32 = [&](std::size_t o) {
    return (std::uint32_t(bytes[o]) << 24) | (std::uint32_t(bytes[o + 1]) << 16) | (std::uint32_t(bytes[o + 2]) << 8) |
           std::uint32_t(bytes[o + 3]);
  };
  return PngHeader{be32(16), be32(20), bytes[24], bytes[25]};
}

std::uint64_t overlay_decode_bytes(std::uint32_t width, std::uint32_t height) {
  // RGBA floats (16 B) plus libpng's rows at up to 16 bits x 4 channels (8 B).
  return std::uint64_t(width) * height * (16 + 8);
}

Result<OverlayImage> read_overlay_png(const fs::path& path, bool premultiplied, const PngLimits& limits) {
  auto bytes = slurp(path, "UI overlay PNG", "png");
  if (!bytes) return bytes.error();
  return read_overlay_named(*bytes, path.string(), premultiplied, limits);
}

Result<OverlayImage> read_overlay_png_memory(std::span<const std::uint8_t> bytes, bool premultiplied,
                                             const PngLimits& limits) {
  return read_overlay_named(bytes, "<memory>", premultiplied, limits);
}

}  // namespace hdrd::io

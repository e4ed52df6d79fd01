// PNG write (16-bit RGB with cICP/mDCV/cLLI for HDR and 10-bit SDR, 8-bit RGB for
// 8-bit SDR) and read (hdrd's chunks back, UI overlays of any colour type).
//
// Writing frames its own chunks (PNG 3rd edition §5) around one zlib stream compressed on
// every core (io/zlib_stream.hpp): libpng compresses on one thread, which made the PNG most
// of what `hdrd encode` waited for (docs/performance.md "Frame I/O"). Reading uses libpng.
//
// libpng reports errors by longjmp. Every setjmp below sits in a function whose C++
// objects all exist before the setjmp, so a longjmp never skips a destructor.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cctype>
#include <csetjmp>
#include <cstring>
#include <fstream>
#include <optional>
#include <span>
#include <thread>

#include <fmt/format.h>
#include <isa-l/crc.h>
#include <png.h>

#include "encode/io/io.hpp"
#include "encode/io/internal.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/io/zlib_stream.hpp"
#include "encode/parallel.hpp"

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

// PNG 3rd edition §11.3.2.6: primaries, transfer, matrix 0 (RGB), full-range flag.
std::vector<std::uint8_t> cicp_for(const DisplayTarget& t) {
  const H273 h = h273(t);
  return {h.primaries, h.transfer, kH273MatrixIdentity,
          static_cast<std::uint8_t>(t.range == Range::full ? 1 : 0)};
}

// mDCV: R, G, B and white x,y as u16 in 0.00002, then max and min luminance as u32 in 0.0001 cd/m2.
std::vector<std::uint8_t> mdcv_for(const MasteringDisplay& m) {
  const St2086Codes c = st2086_codes(m);
  std::vector<std::uint8_t> v;
  for (const auto& xy : {c.red, c.green, c.blue, c.white}) {
    put_u16(v, xy[0]);
    put_u16(v, xy[1]);
  }
  put_u32(v, c.max_luminance);
  put_u32(v, c.min_luminance);
  return v;
}

// cLLI: MaxCLL, MaxFALL as u32 in 0.0001 cd/m2: the values every container carries
// (carried_light_level, encode/frame.hpp), so the PNG states what the sidecar and the KMS
// metadata state (a black frame: the mastering peak, not 0).
std::vector<std::uint8_t> clli_for(const ContentLightLevel& l, const MasteringDisplay& m) {
  std::vector<std::uint8_t> v;
  const CarriedLightLevel c = carried_light_level(l, m);
  put_u32(v, static_cast<std::uint32_t>(c.max_cll_nits) * 10000u);
  put_u32(v, static_cast<std::uint32_t>(c.max_fall_nits) * 10000u);
  return v;
}

// ---- rows -------------------------------------------------------------------------------

struct RowSource {
  const EncodedFrame* frame = nullptr;
  bool sixteen = false;
  bool narrow = false;  // narrow-range frames take their samples from the codes (detail::sample16)

  // The per-row choice is made once per row, not per sample: the writer's inner loops
  // must vectorise (PNG writing at every core's speed, docs/performance.md "Frame I/O").
  void fill(int y, std::uint8_t* row) const {
    const auto& f = *frame;
    const std::uint8_t* src = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    if (!sixteen) {  // XRGB8888 bytes B, G, R, X
      for (int x = 0; x < f.width; ++x) {
        row[x * 3 + 0] = src[x * 4 + 2];
        row[x * 3 + 1] = src[x * 4 + 1];
        row[x * 3 + 2] = src[x * 4 + 0];
      }
      return;
    }
    if (!narrow && !f.signal16.empty()) {  // sample16's first case, row at a time
      const std::uint16_t* s = f.signal16.data() + static_cast<std::size_t>(y) * f.width * 3;
      for (int i = 0; i < f.width * 3; ++i) {
        row[i * 2] = static_cast<std::uint8_t>(s[i] >> 8);
        row[i * 2 + 1] = static_cast<std::uint8_t>(s[i]);
      }
      return;
    }
    for (int x = 0; x < f.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const std::uint16_t s = detail::sample16(f, x, y, c);
        row[x * 6 + c * 2] = static_cast<std::uint8_t>(s >> 8);
        row[x * 6 + c * 2 + 1] = static_cast<std::uint8_t>(s);
      }
  }

};

struct PngWriteJob {
  int width = 0, height = 0, bit_depth = 8;
  RowSource rows;
  std::vector<std::uint8_t> cicp;
  std::vector<std::uint8_t> mdcv, clli;  // empty = not written
  enum class Legacy { none, srgb, gamma22, bt1886 } legacy = Legacy::none;
  PngOptions options;

  std::size_t row_bytes() const { return static_cast<std::size_t>(width) * 3 * (bit_depth / 8); }
  std::size_t pixel_bytes() const { return bit_depth / 8 * 3; }
};

std::uint32_t crc32_of(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0) {
  return crc32_gzip_refl(crc, bytes.data(), bytes.size());  // PNG's CRC-32 (§5.5) is gzip's, reflected
}

// ---- writing: rows, filters, chunks ------------------------------------------------------

// PNG 3rd edition §5.3: length, type, data, CRC-32 over type + data.
void put_chunk(std::vector<std::uint8_t>& out, const char type[4], std::span<const std::uint8_t> data) {
  put_u32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  put_u32(out, crc32_of(std::span(out).subspan(at)));
}

// IHDR, then the colour chunks libpng wrote before (gAMA, sRGB, cHRM), then cICP, mDCV,
// cLLI: all before IDAT, as PNG 3rd edition §5.6 orders them.
void put_header_chunks(std::vector<std::uint8_t>& out, const PngWriteJob& job) {
  out.insert(out.end(), {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'});
  std::vector<std::uint8_t> ihdr;
  put_u32(ihdr, static_cast<std::uint32_t>(job.width));
  put_u32(ihdr, static_cast<std::uint32_t>(job.height));
  ihdr.insert(ihdr.end(), {static_cast<std::uint8_t>(job.bit_depth), 2, 0, 0, 0});  // RGB, deflate, filter set 0, no interlace
  put_chunk(out, "IHDR", ihdr);
  using L = PngWriteJob::Legacy;
  if (job.legacy != L::none) {
    // gAMA holds the encoding exponent x 100000: 1/2.2 -> 45455 (also sRGB's, §11.3.3.5), 1/2.4 -> 41667.
    std::vector<std::uint8_t> gama;
    put_u32(gama, job.legacy == L::bt1886 ? 41667 : 45455);
    put_chunk(out, "gAMA", gama);
    if (job.legacy == L::srgb) put_chunk(out, "sRGB", std::array<std::uint8_t, 1>{0});  // perceptual
    // cHRM: BT.709 / sRGB primaries and D65 x 100000.
    std::vector<std::uint8_t> chrm;
    for (std::uint32_t v : {31270u, 32900u, 64000u, 33000u, 30000u, 60000u, 15000u, 6000u}) put_u32(chrm, v);
    put_chunk(out, "cHRM", chrm);
  }
  put_chunk(out, "cICP", job.cicp);
  if (!job.mdcv.empty()) put_chunk(out, "mDCV", job.mdcv);
  if (!job.clli.empty()) put_chunk(out, "cLLI", job.clli);
}

// Row filters (PNG 3rd edition §9.2, filter method 0) on the raw bytes of one scan line;
// `bpp` bytes per pixel, `above` the raw line above (zeros for the first). The encoder
// reads only raw bytes, so every filter is a loop without a serial dependency.
enum class Filter : std::uint8_t { none = 0, sub = 1, up = 2, average = 3, paeth = 4 };

void filter_line(Filter f, const std::uint8_t* __restrict raw, const std::uint8_t* __restrict above, std::size_t n,
                 std::size_t bpp, std::uint8_t* __restrict out) {
  const std::size_t lead = std::min(bpp, n);  // the first pixel has no left neighbour (a = c = 0)
  switch (f) {
    case Filter::none: std::memcpy(out, raw, n); return;
    case Filter::sub:
      std::memcpy(out, raw, lead);
      for (std::size_t i = lead; i < n; ++i) out[i] = static_cast<std::uint8_t>(raw[i] - raw[i - bpp]);
      return;
    case Filter::up:
      for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<std::uint8_t>(raw[i] - above[i]);
      return;
    case Filter::average:
      for (std::size_t i = 0; i < lead; ++i) out[i] = static_cast<std::uint8_t>(raw[i] - (above[i] >> 1));
      for (std::size_t i = lead; i < n; ++i)
        out[i] = static_cast<std::uint8_t>(raw[i] - ((raw[i - bpp] + above[i]) >> 1));
      return;
    case Filter::paeth:
      for (std::size_t i = 0; i < lead; ++i) out[i] = static_cast<std::uint8_t>(raw[i] - above[i]);  // Paeth(0, b, 0) = b
      for (std::size_t i = lead; i < n; ++i) {
        const int a = raw[i - bpp], b = above[i], c = above[i - bpp];
        const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);  // |p-a|, |p-b|, |p-c|
        const int pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
        out[i] = static_cast<std::uint8_t>(raw[i] - pred);
      }
      return;
  }
}

// PNG §12.8's heuristic (libpng's default): the filter whose output, read as signed
// bytes, has the smallest sum of magnitudes. `trial` holds 5 lines of scratch.
Filter adaptive_filter_line(const std::uint8_t* raw, const std::uint8_t* above, std::size_t n, std::size_t bpp,
                            std::uint8_t* trial, std::uint8_t* out) {
  Filter best = Filter::none;
  std::uint64_t best_sum = UINT64_MAX;
  for (int f = 0; f < 5; ++f) {
    std::uint8_t* t = trial + n * static_cast<std::size_t>(f);
    filter_line(static_cast<Filter>(f), raw, above, n, bpp, t);
    std::uint64_t sum = 0;
    for (std::size_t i = 0; i < n; ++i) sum += static_cast<std::uint64_t>(std::abs(static_cast<std::int8_t>(t[i])));
    if (sum < best_sum) {
      best_sum = sum;
      best = static_cast<Filter>(f);
    }
  }
  std::memcpy(out, trial + n * static_cast<std::size_t>(best), n);
  return best;
}

// ---- writing: the image data on every core ----------------------------------------------
// The filtered scan lines (PNG §7.2: a filter-type byte, then the filtered line) are cut into
// segments of whole lines, each deflated on its own as part of one zlib stream
// (io/zlib_stream.hpp) and written as its own IDAT chunk (§11.2.4: the IDATs' data,
// concatenated, is the stream). The segments depend on the image size only, so the file is
// the same whatever the thread count.

constexpr std::size_t kSegmentBytes = std::size_t{1} << 20;  // ~2-5 ms of work: even load, small flush overhead

// Filters by level (docs/dump-format.md "PNG compression", measured on hdrd's frames of the
// EXR fixtures): none when storing; Sub on every line for the fast levels (1-2 % smaller
// than Up on photographs, the same single subtraction); for the small-file levels the
// per-line choice of §12.8 (1-5 % smaller than Sub, five filters' work per line).
std::optional<Filter> filter_for(int level) {
  if (level == 0) return Filter::none;
  if (level <= 3) return Filter::sub;
  return std::nullopt;  // adaptive
}

struct Segments {
  int rows_per_segment = 1;
  int count = 0;
  int dictionary_rows = 0;  // rows before a segment that fill the deflate window
};

Segments plan_segments(const PngWriteJob& job) {
  const std::size_t line = job.row_bytes() + 1;
  Segments s;
  s.rows_per_segment = static_cast<int>(std::clamp<std::size_t>(kSegmentBytes / line, 1, static_cast<std::size_t>(job.height)));
  s.count = (job.height + s.rows_per_segment - 1) / s.rows_per_segment;
  s.dictionary_rows = static_cast<int>((detail::kDeflateWindowBytes + line - 1) / line);
  return s;
}

// One thread's buffers: two raw lines, five trial lines, and the filtered lines of a
// segment with its dictionary.
struct SegmentScratch {
  std::vector<std::uint8_t> above, raw, trial, filtered;
};

// Filters lines [y_begin, y_end) into scratch.filtered, each with its filter-type byte.
void filter_lines(const PngWriteJob& job, int y_begin, int y_end, SegmentScratch& s) {
  const std::size_t n = job.row_bytes(), line = n + 1;
  const std::optional<Filter> fixed = filter_for(job.options.level);
  const bool needs_above = !fixed;  // None and Sub read only the line itself
  s.filtered.resize(line * static_cast<std::size_t>(y_end - y_begin));
  s.above.assign(n, 0);  // §9.2: the line above the first is all zeros
  s.raw.resize(n);
  if (!fixed) s.trial.resize(5 * n);
  if (y_begin > 0 && needs_above) job.rows.fill(y_begin - 1, s.above.data());
  for (int y = y_begin; y < y_end; ++y) {
    std::uint8_t* out = s.filtered.data() + line * static_cast<std::size_t>(y - y_begin);
    job.rows.fill(y, s.raw.data());
    if (fixed) {
      out[0] = static_cast<std::uint8_t>(*fixed);
      filter_line(*fixed, s.raw.data(), s.above.data(), n, job.pixel_bytes(), out + 1);
    } else {
      out[0] = static_cast<std::uint8_t>(
          adaptive_filter_line(s.raw.data(), s.above.data(), n, job.pixel_bytes(), s.trial.data(), out + 1));
    }
    if (needs_above) s.above.swap(s.raw);
  }
}

struct SegmentOut {
  std::vector<std::uint8_t> chunk;  // length, "IDAT", data and (but for the last) CRC
  std::uint32_t adler = 1;          // of the segment's filtered bytes
  std::size_t raw_bytes = 0;
};

Result<void> compress_segment(const PngWriteJob& job, const Segments& plan, int index, SegmentScratch& scratch,
                              detail::SegmentDeflater& deflater, SegmentOut& out) {
  const int y0 = index * plan.rows_per_segment, y1 = std::min(job.height, y0 + plan.rows_per_segment);
  const int ya = std::max(0, y0 - plan.dictionary_rows);
  filter_lines(job, ya, y1, scratch);
  const std::size_t dict_bytes = (job.row_bytes() + 1) * static_cast<std::size_t>(y0 - ya);
  const std::span<const std::uint8_t> all(scratch.filtered);
  const auto data = all.subspan(dict_bytes);
  out.chunk.clear();
  out.chunk.reserve(data.size() + data.size() / 16 + 64);
  out.chunk.insert(out.chunk.end(), {0, 0, 0, 0, 'I', 'D', 'A', 'T'});
  if (index == 0) {
    const auto header = detail::zlib_header(job.options.level);
    out.chunk.insert(out.chunk.end(), header.begin(), header.end());
  }
  const bool last = index == plan.count - 1;
  if (auto ok = deflater.deflate(all.first(dict_bytes), data, last, out.chunk); !ok) return ok;
  out.adler = detail::adler32(data);
  out.raw_bytes = data.size();
  if (!last) {  // the last chunk is closed once the stream's Adler-32 is known
    const auto length = static_cast<std::uint32_t>(out.chunk.size() - 8);
    for (int i = 0; i < 4; ++i) out.chunk[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(length >> (24 - 8 * i));
    put_u32(out.chunk, crc32_of(std::span(out.chunk).subspan(4)));
  }
  return {};
}

// Segments handed out dynamically to `threads` runners of the shared pool (the caller is one).
Result<std::vector<SegmentOut>> compress_image(const PngWriteJob& job) {
  const Segments plan = plan_segments(job);
  std::vector<SegmentOut> segments(static_cast<std::size_t>(plan.count));
  const int threads = std::clamp(job.options.threads > 0 ? job.options.threads : hardware_threads(), 1, plan.count);
  std::atomic<int> next{0};
  std::vector<std::optional<Error>> failures(static_cast<std::size_t>(threads));
  auto worker = [&](int w) {
    try {
      SegmentScratch scratch;
      detail::SegmentDeflater deflater(job.options.level);
      for (int i = next.fetch_add(1); i < plan.count; i = next.fetch_add(1))
        if (auto ok = compress_segment(job, plan, i, scratch, deflater, segments[static_cast<std::size_t>(i)]); !ok) {
          failures[static_cast<std::size_t>(w)] = ok.error();
          next = plan.count;  // the others stop at their next segment
        }
    } catch (const std::bad_alloc&) {
      failures[static_cast<std::size_t>(w)] = make_error("png.write", "cannot encode PNG: out of memory");
      next = plan.count;
    }
  };
  parallel_run(threads, worker);  // the shared pool (encode/parallel.hpp)
  for (auto& f : failures)
    if (f) return *f;
  return segments;
}

// The last IDAT gets the stream's Adler-32 (RFC 1950 §2.2, big-endian), its length and CRC.
void close_stream(std::vector<SegmentOut>& segments) {
  std::uint32_t adler = segments.front().adler;
  for (std::size_t i = 1; i < segments.size(); ++i)
    adler = detail::adler32_combine(adler, segments[i].adler, segments[i].raw_bytes);
  auto& chunk = segments.back().chunk;
  put_u32(chunk, adler);
  const auto length = static_cast<std::uint32_t>(chunk.size() - 8);
  for (int i = 0; i < 4; ++i) chunk[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(length >> (24 - 8 * i));
  put_u32(chunk, crc32_of(std::span(chunk).subspan(4)));
}

Result<std::vector<std::uint8_t>> run_png_write(const PngWriteJob& job) {
  auto segments = compress_image(job);
  if (!segments) return segments.error();
  close_stream(*segments);
  std::vector<std::uint8_t> out;
  std::size_t total = 256 + job.mdcv.size() + job.clli.size();
  for (const auto& s : *segments) total += s.chunk.size();
  out.reserve(total);
  put_header_chunks(out, job);
  for (const auto& s : *segments) out.insert(out.end(), s.chunk.begin(), s.chunk.end());
  put_chunk(out, "IEND", {});
  return out;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_png(const EncodedFrame& frame, const PngOptions& options) {
  if (frame.target.mode == Mode::scrgb)
    return make_error("png.unsupported", "scrgb has no PNG form (PNG cannot hold FP16 scRGB); use exr or raw",
                      "format");
  if (auto ok = check_png_options(options); !ok) return ok.error();
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  PngWriteJob job;
  job.width = frame.width;
  job.height = frame.height;
  job.options = options;
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
  try {
    return run_png_write(job);
  } catch (const std::bad_alloc&) {
    return make_error("png.write", "cannot encode PNG: out of memory");
  }
}

Result<void> check_png_options(const PngOptions& options) {
  if (options.level < kMinPngLevel || options.level > kMaxPngLevel)
    return make_error("png.level", fmt::format("PNG level {} is out of range ({} stored .. {} smallest)", options.level,
                                               kMinPngLevel, kMaxPngLevel),
                      "png_level");
  if (options.threads < 0)
    return make_error("png.threads", fmt::format("PNG threads {} is negative (0 = every core)", options.threads),
                      "threads");
  return {};
}

Result<void> write_png(const fs::path& path, const EncodedFrame& frame, const PngOptions& options,
                       const WriteOptions& write) {
  auto bytes = encode_png(frame, options);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes, write);
}

// ---- reading ----------------------------------------------------------------------------

namespace {

// A PNG's lengths and sizes: big-endian (PNG 3rd ed. §7.1). The caller checks the bounds.
std::uint32_t read_be32(std::span<const std::uint8_t> b, std::size_t at) {
  return (std::uint32_t(b[at]) << 24) | (std::uint32_t(b[at + 1]) << 16) | (std::uint32_t(b[at + 2]) << 8) |
         std::uint32_t(b[at + 3]);
}

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

// Every chunk's declared length against the bytes there are, before libpng sees them: libpng
// allocates a chunk's buffer from its length field before reading the data, so a 101-byte
// file whose sPLT claims 1.5 GiB made it allocate 1.5 GiB (found by png_fuzz; its
// chunk_malloc_max did not stop it).
std::optional<Error> check_chunk_lengths(std::span<const std::uint8_t> bytes, const std::string& name) {
  std::size_t at = 8;  // after the signature
  while (bytes.size() - at >= 8) {
    const std::uint32_t n = read_be32(bytes, at);
    std::string type(reinterpret_cast<const char*>(bytes.data() + at + 4), 4);
    for (char& ch : type)
      if (!std::isalpha(static_cast<unsigned char>(ch))) ch = '?';
    const std::size_t left = bytes.size() - at - 8;
    if (n > 0x7fffffffu || std::size_t(n) + 4 > left)
      return make_error("png.truncated", fmt::format("cannot read PNG {}: its {} chunk declares {} bytes, {} are left in "
                                                     "the file", name, type, n, left >= 4 ? left - 4 : 0));
    if (type == "IEND") return std::nullopt;
    at += 12 + std::size_t(n);
  }
  return std::nullopt;  // libpng reports the missing IEND as truncation
}

// Decodes the whole image into job.pixels (big-endian 16-bit samples when out_depth is 16).
Result<void> decode(PngReadJob& job, const std::string& name, PngInfo* chunks_out) {
  if (job.bytes.size() < 8 || png_sig_cmp(job.bytes.data(), 0, 8) != 0)
    return make_error("png.not_png", fmt::format("cannot read PNG {}: not a PNG file (bad signature)", name));
  job.error.limits = job.limits;
  if (auto bad = check_chunk_lengths(job.bytes, name)) return *bad;
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

Result<std::vector<std::uint8_t>> slurp(const fs::path& path, const char* what, const char* code_prefix,
                                        const InputFiles& files) {
  const std::string name = path.string(), prefix(code_prefix);
  auto fd = files.open(path);
  if (!fd) return reader_error(fd.error(), prefix + ".missing", prefix + ".unreadable");
  auto bytes = read_all(fd->get(), name, std::size_t{1} << 31);
  if (!bytes && bytes.error().code == "file.too_large")
    return make_error(prefix + ".size", fmt::format("cannot read {} {}: file larger than 2 GiB", what, name));
  if (!bytes) return reader_error(bytes.error(), prefix + ".missing", prefix + ".unreadable");
  return std::vector<std::uint8_t>(bytes->begin(), bytes->end());
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

Result<PngInfo> read_png_info(const fs::path& path, const InputFiles& files) {
  auto bytes = slurp(path, "PNG", "png", files);
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
  return PngHeader{read_be32(bytes, 16), read_be32(bytes, 20), bytes[24], bytes[25]};
}

std::uint64_t overlay_decode_bytes(std::uint32_t width, std::uint32_t height) {
  // RGBA floats (16 B) plus libpng's rows at up to 16 bits x 4 channels (8 B).
  return std::uint64_t(width) * height * (16 + 8);
}

Result<OverlayImage> read_overlay_png(const fs::path& path, bool premultiplied, const PngLimits& limits,
                                      const InputFiles& files) {
  auto bytes = slurp(path, "UI overlay PNG", "png", files);
  if (!bytes) return bytes.error();
  return read_overlay_named(*bytes, path.string(), premultiplied, limits);
}

Result<OverlayImage> read_overlay_png_memory(std::span<const std::uint8_t> bytes, bool premultiplied,
                                             const PngLimits& limits) {
  return read_overlay_named(bytes, "<memory>", premultiplied, limits);
}

}  // namespace hdrd::io

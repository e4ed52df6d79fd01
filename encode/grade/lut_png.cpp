// The identity-LUT workflow (Selan, GPU Gems 2 ch. 24): the lattice sliced into a 16-bit
// PNG strip that an image editor grades like a picture, read back into a LUT. libpng is
// used directly (classic API: the simplified API would linearise 8-bit sRGB samples, and a
// strip holds data, not colours to convert).
#include <png.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <memory>

#include "encode/grade/lut.hpp"

namespace hdrd::lut {

namespace {
constexpr const char* kTextKey = "hdrd-lut";

struct FileCloser {
  void operator()(std::FILE* f) const { if (f) std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

void on_png_error(png_structp png, png_const_charp msg) {
  auto* text = static_cast<std::string*>(png_get_error_ptr(png));
  if (text) *text = msg;
  png_longjmp(png, 1);
}
void on_png_warning(png_structp, png_const_charp) {}
}  // namespace

Strip identity_strip(int size) {
  Strip s;
  s.size = size;
  const std::size_t width = std::size_t(size) * size;
  s.rgb.resize(width * size * 3);
  const auto code = [&](int i) { return static_cast<std::uint16_t>(std::lround(65535.0 * i / (size - 1))); };
  for (int y = 0; y < size; ++y)
    for (std::size_t x = 0; x < width; ++x) {
      std::uint16_t* p = &s.rgb[(y * width + x) * 3];
      p[0] = code(int(x % size));
      p[1] = code(y);
      p[2] = code(int(x / size));
    }
  return s;
}

Lut3D lut_from_strip(const Strip& strip) {
  const int n = strip.size;
  const std::size_t width = std::size_t(n) * n;
  Lut3D l;
  l.size = n;
  l.rgb.resize(std::size_t(n) * n * n * 3);
  for (int b = 0; b < n; ++b)
    for (int g = 0; g < n; ++g)
      for (int r = 0; r < n; ++r) {
        const std::uint16_t* p = &strip.rgb[(g * width + std::size_t(b) * n + r) * 3];
        for (int c = 0; c < 3; ++c) l.rgb[l.index(r, g, b) + c] = static_cast<float>(p[c] / 65535.0);
      }
  return l;
}

Result<void> write_strip_png(const Strip& strip, const std::filesystem::path& path, const std::string& text) {
  const int n = strip.size;
  if (n < kMin3DSize || n > kMaxStripSize)
    return make_error("strip.size", fmt::format("strip size {} is outside {}..{}", n, kMin3DSize, kMaxStripSize), "size");
  File f(std::fopen(path.c_str(), "wb"));
  if (!f) return make_error("strip.io", fmt::format("{}: cannot write", path.string()), "output");
  std::string err;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, on_png_error, on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return make_error("strip.io", "libpng: out of memory", "output");
  }
  const std::size_t width = std::size_t(n) * n;
  std::vector<png_byte> row(width * 6);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return make_error("strip.io", fmt::format("{}: libpng: {}", path.string(), err), "output");
  }
  png_init_io(png, f.get());
  png_set_compression_level(png, 6);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(n), 16, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_text t{};
  t.compression = PNG_TEXT_COMPRESSION_NONE;
  t.key = const_cast<char*>(kTextKey);
  t.text = const_cast<char*>(text.c_str());
  png_set_text(png, info, &t, 1);
  png_write_info(png, info);
  for (int y = 0; y < n; ++y) {
    for (std::size_t i = 0; i < width * 3; ++i) {  // PNG samples are big-endian
      const std::uint16_t v = strip.rgb[y * width * 3 + i];
      row[2 * i] = static_cast<png_byte>(v >> 8);
      row[2 * i + 1] = static_cast<png_byte>(v & 0xFF);
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(f.get()) != 0) return make_error("strip.io", fmt::format("{}: write failed", path.string()), "output");
  return {};
}

namespace {

struct PngShape {
  png_uint_32 width = 0, height = 0;
  int depth = 0, color = 0;
};

Result<void> check_shape(const PngShape& s, const std::filesystem::path& path, int& n) {
  n = static_cast<int>(s.height);
  if (s.height < png_uint_32(kMin3DSize) || s.height > png_uint_32(kMaxStripSize) ||
      std::uint64_t(s.width) != std::uint64_t(s.height) * s.height)
    return make_error("strip.size", fmt::format("{}: {}x{} is not a LUT strip (size N is N*N x N, N in {}..{}); "
                                                "was the image cropped or resized?",
                                                path.string(), s.width, s.height, kMin3DSize, kMaxStripSize), "input");
  if (s.color != PNG_COLOR_TYPE_RGB && s.color != PNG_COLOR_TYPE_RGB_ALPHA)
    return make_error("strip.format", fmt::format("{}: not an RGB PNG (grey or palette image)", path.string()), "input");
  if (s.depth != 8 && s.depth != 16)
    return make_error("strip.format", fmt::format("{}: {}-bit samples; expected 16 (or 8)", path.string(), s.depth), "input");
  return {};
}

}  // namespace

Result<Strip> read_strip_png(const std::filesystem::path& path, std::string* text, std::vector<std::string>* warnings) {
  // Opened as the file model opens a file given as is: a FIFO is refused, not waited on.
  auto fd = io::open_regular(path);
  if (!fd) return io::reader_error(fd.error(), "strip.io", "strip.io", "input");
  File f(::fdopen(fd->get(), "rb"));
  if (!f) return make_error("strip.io", fmt::format("{}: cannot open", path.string()), "input");
  fd->release();  // the FILE owns it now
  png_byte sig[8] = {};
  if (std::fread(sig, 1, 8, f.get()) != 8 || png_sig_cmp(sig, 0, 8) != 0)
    return make_error("strip.format", fmt::format("{}: not a PNG file", path.string()), "input");
  std::string err;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, on_png_error, on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return make_error("strip.io", "libpng: out of memory", "input");
  }
  // Everything with a destructor lives outside the setjmp scope (libpng longjmps on error).
  Strip strip;
  std::vector<png_byte> row, image;
  std::vector<png_bytep> rows;
  Error shape_error;
  volatile bool bad_shape = false;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return make_error("strip.format", fmt::format("{}: libpng: {}", path.string(), err), "input");
  }
  png_init_io(png, f.get());
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  PngShape s{png_get_image_width(png, info), png_get_image_height(png, info), png_get_bit_depth(png, info),
             png_get_color_type(png, info)};
  int n = 0;
  if (auto ok = check_shape(s, path, n); !ok) {
    shape_error = ok.error();
    bad_shape = true;
  } else {
    if (png_get_interlace_type(png, info) != PNG_INTERLACE_NONE) png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const int channels = s.color == PNG_COLOR_TYPE_RGB_ALPHA ? 4 : 3;
    const int bytes = s.depth / 8;
    row.resize(png_get_rowbytes(png, info));
    strip.size = n;
    strip.rgb.resize(std::size_t(s.width) * n * 3);
    image.resize(row.size() * n);
    rows.resize(n);
    for (int y = 0; y < n; ++y) rows[y] = image.data() + row.size() * y;
    png_read_image(png, rows.data());
    for (int y = 0; y < n; ++y)
      for (std::size_t x = 0; x < s.width; ++x)
        for (int c = 0; c < 3; ++c) {
          const png_byte* p = rows[y] + (x * channels + c) * bytes;
          const std::uint16_t v = bytes == 2 ? std::uint16_t(p[0] << 8 | p[1]) : std::uint16_t(p[0] * 257);
          strip.rgb[(y * s.width + x) * 3 + c] = v;
        }
    png_textp texts = nullptr;
    int count = 0;
    png_read_end(png, info);
    if (text && png_get_text(png, info, &texts, &count) > 0)
      for (int i = 0; i < count; ++i)
        if (std::string_view(texts[i].key) == kTextKey) *text = texts[i].text;
    if (warnings && s.depth == 8)
      warnings->push_back(fmt::format("{}: 8-bit strip: the LUT is only precise to 1/255; save it as 16-bit",
                                      path.string()));
    if (warnings && channels == 4) warnings->push_back(fmt::format("{}: alpha channel ignored", path.string()));
  }
  png_destroy_read_struct(&png, &info, nullptr);
  if (bad_shape) return shape_error;
  return strip;
}

namespace {

// Edge residuals at one scale w: the edge value against the straight line through the
// points w and 2w inside the slice. A blur of radius < w leaves those points alone and
// moves the edge toward the neighbouring slice; a smooth colour edit moves it by about
// its own curvature, which `noise` (the same second difference inside slices) measures.
SpatialEditCheck edge_pulls(const Lut3D& lut, int w) {
  const int n = lut.size;
  const auto R = [&](int ri, int g, int b) { return double(lut.rgb[lut.index(ri, g, b)]); };
  // A value pinned at 0 or 1 was clipped by the 16-bit image, not moved by a filter.
  const auto clipped = [](double v) { return v < 1e-4 || v > 1 - 1e-4; };
  SpatialEditCheck r;
  int right = 0, left = 0, interior = 0;
  for (int b = 0; b < n; ++b)
    for (int g = 0; g < n; ++g) {
      for (int i = 2 * w; i <= n - 1 - 2 * w; ++i, ++interior)
        r.noise += std::fabs(R(i + w, g, b) - 2 * R(i, g, b) + R(i - w, g, b));
      if (b + 1 >= n) continue;
      // The right edge of slice b (r = N-1) touches the left edge (r = 0) of slice b+1.
      const double res_right = R(n - 1, g, b) - (2 * R(n - 1 - w, g, b) - R(n - 1 - 2 * w, g, b));
      const double res_left = R(0, g, b + 1) - (2 * R(w, g, b + 1) - R(2 * w, g, b + 1));
      const double dir = R(0, g, b + 1) > R(n - 1, g, b) ? 1.0 : -1.0;  // right edge -> its neighbour
      if (!clipped(R(n - 1, g, b))) r.pull_right += res_right * dir, ++right;
      if (!clipped(R(0, g, b + 1))) r.pull_left -= res_left * dir, ++left;
    }
  const int edges = n * (n - 1);
  if (right * 10 < edges || left * 10 < edges) return r;  // mostly clipped: no verdict
  r.pull_right /= right;
  r.pull_left /= left;
  if (interior) r.noise /= interior;
  // Both edges must move toward each other by more than 1 % and well beyond the slices'
  // own curvature: a colour edit that clips or lifts one end moves only one edge.
  const double threshold = std::max(0.01, 4.0 * r.noise);
  r.suspected = r.pull_right > threshold && r.pull_left > threshold;
  return r;
}

}  // namespace

SpatialEditCheck detect_spatial_edit(const Lut3D& lut) {
  SpatialEditCheck worst;
  for (int w = 1; w <= 3 && 4 * w + 1 <= lut.size; ++w) {
    const auto c = edge_pulls(lut, w);
    if (c.suspected || (!worst.suspected && std::min(c.pull_right, c.pull_left) >
                                                std::min(worst.pull_right, worst.pull_left)))
      worst = c;
    if (c.suspected) break;
  }
  return worst;
}

}  // namespace hdrd::lut

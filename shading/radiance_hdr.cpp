#include "shading/radiance_hdr.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

namespace hdrd::shading {
namespace {

constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
constexpr std::size_t kMaxLineBytes = 4096;
constexpr std::uintmax_t kMaxFileBytes = 4ull << 30;
// Radiance's MINELEN / MAXELEN: scanlines of this length may use per-channel run lengths.
constexpr int kMinRleLength = 8, kMaxRleLength = 0x7fff;

Error hdr_error(std::string code, std::string what) { return make_error("hdr." + code, std::move(what), "environment.file"); }

class Cursor {
 public:
  explicit Cursor(std::span<const std::uint8_t> b) : bytes_(b) {}
  std::size_t left() const { return bytes_.size() - pos_; }
  std::size_t pos() const { return pos_; }
  bool byte(std::uint8_t& out) {
    if (pos_ >= bytes_.size()) return false;
    out = bytes_[pos_++];
    return true;
  }
  bool take(std::uint8_t* out, std::size_t n) {
    if (left() < n) return false;
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  // One text line without its '\n'; false at the end of the data or past kMaxLineBytes.
  bool line(std::string& out) {
    out.clear();
    while (pos_ < bytes_.size()) {
      const char c = static_cast<char>(bytes_[pos_++]);
      if (c == '\n') return true;
      if (out.size() >= kMaxLineBytes) return false;
      out.push_back(c);
    }
    return false;
  }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t pos_ = 0;
};

// Whitespace-separated finite numbers; exactly `count` of them.
template <std::size_t N>
bool parse_numbers(std::string_view s, std::array<double, N>& out) {
  std::size_t k = 0;
  const char* p = s.data();
  const char* end = s.data() + s.size();
  while (true) {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p == end) break;
    if (k == N) return false;
    const auto [next, ec] = std::from_chars(p, end, out[k]);
    if (ec != std::errc() || !std::isfinite(out[k])) return false;
    p = next;
    ++k;
  }
  return k == N;
}

struct Header {
  bool xyz = false;
  double exposure = 1.0;
  std::array<double, 3> colorcorr{1, 1, 1};
  std::optional<color::Primaries> primaries;
  std::vector<std::string> warnings;
};

Result<void> header_variable(std::string_view line, Header& h) {
  const auto value = [&](std::string_view key) { return line.substr(key.size()); };
  if (line.rfind("FORMAT=", 0) == 0) {
    std::string_view f = value("FORMAT=");
    while (!f.empty() && (f.back() == ' ' || f.back() == '\r')) f.remove_suffix(1);
    if (f == "32-bit_rle_rgbe") h.xyz = false;
    else if (f == "32-bit_rle_xyze") h.xyz = true;
    else return hdr_error("format", fmt::format("FORMAT={} is not 32-bit_rle_rgbe or 32-bit_rle_xyze", f));
  } else if (line.rfind("EXPOSURE=", 0) == 0) {
    std::array<double, 1> e{};
    if (!parse_numbers(value("EXPOSURE="), e) || !(e[0] > 0))
      return hdr_error("header", fmt::format("'{}' is not a positive EXPOSURE", line));
    h.exposure *= e[0];  // "cumulative: multiply them" (Radiance picture format)
  } else if (line.rfind("COLORCORR=", 0) == 0) {
    std::array<double, 3> c{};
    if (!parse_numbers(value("COLORCORR="), c) || !(c[0] > 0 && c[1] > 0 && c[2] > 0))
      return hdr_error("header", fmt::format("'{}' is not three positive COLORCORR factors", line));
    for (int i = 0; i < 3; ++i) h.colorcorr[i] *= c[i];
  } else if (line.rfind("PRIMARIES=", 0) == 0) {
    std::array<double, 8> p{};
    if (!parse_numbers(value("PRIMARIES="), p))
      return hdr_error("header", fmt::format("'{}' is not eight PRIMARIES chromaticities", line));
    for (int i = 0; i < 8; i += 2)
      if (!(p[i] > -1 && p[i] < 2 && p[i + 1] > 0 && p[i + 1] < 2))
        return hdr_error("header", fmt::format("'{}': chromaticity out of range", line));
    h.primaries = color::Primaries{{p[0], p[1]}, {p[2], p[3]}, {p[4], p[5]}, {p[6], p[7]}};
  } else if (line.rfind("PIXASPECT=", 0) == 0) {
    h.warnings.push_back(fmt::format("ignoring {} (pixels are read as square)", line));
  }
  return {};
}

Result<Header> read_header(Cursor& c) {
  std::string line;
  if (!c.line(line) || line.rfind("#?", 0) != 0)
    return hdr_error("signature", "not a Radiance picture (no \"#?RADIANCE\" first line)");
  Header h;
  while (true) {
    if (c.pos() > kMaxHeaderBytes) return hdr_error("header", "header longer than 64 KiB");
    if (!c.line(line)) return hdr_error("truncated", "header has no end (no empty line)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) break;
    if (line[0] == '#') continue;
    if (auto r = header_variable(line, h); !r) return r.error();
  }
  return h;
}

// The resolution string, e.g. "-Y 512 +X 1024": scanline axis first, then pixel axis.
struct Layout {
  int width = 0, height = 0;
  bool scan_is_y = true;           // scanlines are rows (else columns)
  bool scan_forward = true;        // scanline i is row/column i (else counted from the other end)
  bool pixel_forward = true;       // pixel j is column/row j
  int scanlines = 0, scan_length = 0;
};

Result<Layout> read_layout(Cursor& c) {
  std::string line;
  if (!c.line(line)) return hdr_error("truncated", "no resolution line after the header");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  char s1 = 0, a1 = 0, s2 = 0, a2 = 0;
  long n1 = 0, n2 = 0;
  char extra = 0;
  if (std::sscanf(line.c_str(), " %c%c %ld %c%c %ld %c", &s1, &a1, &n1, &s2, &a2, &n2, &extra) != 6 ||
      (s1 != '+' && s1 != '-') || (s2 != '+' && s2 != '-') || (a1 != 'X' && a1 != 'Y') || (a2 != 'X' && a2 != 'Y') ||
      a1 == a2)
    return hdr_error("resolution", fmt::format("'{}' is not a resolution string such as \"-Y 512 +X 1024\"",
                                               line.substr(0, 80)));
  Layout l;
  l.scan_is_y = a1 == 'Y';
  const long w = l.scan_is_y ? n2 : n1, h = l.scan_is_y ? n1 : n2;
  if (auto r = check_image_size(w, h); !r) return hdr_error("size", r.error().message);
  l.width = static_cast<int>(w);
  l.height = static_cast<int>(h);
  // Radiance's Y axis points up: "-Y" scans from the top, "+Y" from the bottom.
  l.scan_forward = l.scan_is_y ? s1 == '-' : s1 == '+';
  l.pixel_forward = l.scan_is_y ? s2 == '+' : s2 == '-';
  l.scanlines = static_cast<int>(n1);
  l.scan_length = static_cast<int>(n2);
  return l;
}

// New-style run lengths: the four byte planes of the scanline one after another.
Result<void> read_rle_planes(Cursor& c, std::uint8_t* out, int length, int scanline) {
  for (int plane = 0; plane < 4; ++plane) {
    int j = 0;
    while (j < length) {
      std::uint8_t code = 0, value = 0;
      if (!c.byte(code)) return hdr_error("truncated", fmt::format("data ends in scanline {}", scanline));
      if (code > 128) {
        const int run = code - 128;
        if (j + run > length || !c.byte(value))
          return hdr_error("rle", fmt::format("scanline {}: run of {} overflows the {} pixels", scanline, run, length));
        for (int k = 0; k < run; ++k) out[(j++) * 4 + plane] = value;
      } else {
        if (j + code > length)
          return hdr_error("rle", fmt::format("scanline {}: {} literal bytes overflow the {} pixels", scanline, code, length));
        for (int k = 0; k < code; ++k, ++j)
          if (!c.byte(out[j * 4 + plane])) return hdr_error("truncated", fmt::format("data ends in scanline {}", scanline));
      }
    }
  }
  return {};
}

// Flat pixels with the old-style repeat marker (1, 1, 1, n): repeat the previous pixel
// n << shift times, the shift growing by 8 for consecutive markers (Radiance oldreadcolrs).
Result<void> read_old_scanline(Cursor& c, std::uint8_t* out, int length, int scanline, int j) {
  int shift = 0;
  while (j < length) {
    std::uint8_t* px = out + static_cast<std::size_t>(j) * 4;
    if (!c.take(px, 4)) return hdr_error("truncated", fmt::format("data ends in scanline {}", scanline));
    if (px[0] == 1 && px[1] == 1 && px[2] == 1) {
      if (j == 0 || shift > 16)
        return hdr_error("rle", fmt::format("scanline {}: repeat marker without a pixel to repeat", scanline));
      const std::int64_t count = static_cast<std::int64_t>(px[3]) << shift;
      if (j + count > length)
        return hdr_error("rle", fmt::format("scanline {}: repeat of {} overflows the {} pixels", scanline, count, length));
      for (std::int64_t k = 0; k < count; ++k, ++j) std::memcpy(out + static_cast<std::size_t>(j) * 4, out + (j - 1) * 4, 4);
      shift += 8;
    } else {
      ++j;
      shift = 0;
    }
  }
  return {};
}

Result<void> read_scanline(Cursor& c, std::uint8_t* out, int length, int scanline) {
  if (length < kMinRleLength || length > kMaxRleLength) return read_old_scanline(c, out, length, scanline, 0);
  if (!c.take(out, 4)) return hdr_error("truncated", fmt::format("data ends at scanline {}", scanline));
  if (out[0] != 2 || out[1] != 2 || (out[2] & 0x80)) return read_old_scanline(c, out, length, scanline, 1);
  if (((out[2] << 8) | out[3]) != length)
    return hdr_error("rle", fmt::format("scanline {} says it has {} pixels, the image {}", scanline,
                                        (out[2] << 8) | out[3], length));
  return read_rle_planes(c, out, length, scanline);
}

// colr_color(): (m + 0.5) * 2^(e - 136); exponent 0 is black.
float decode_channel(std::uint8_t m, std::uint8_t e) {
  return e == 0 ? 0.0f : static_cast<float>(std::ldexp(m + 0.5, int(e) - 136));
}

Result<Image> decode_pixels(Cursor& c, const Layout& l) {
  const std::size_t total = static_cast<std::size_t>(l.width) * l.height;
  std::vector<std::uint8_t> line(static_cast<std::size_t>(l.scan_length) * 4);
  // Grow with the data actually read: a short file claiming a huge size fails before
  // anything of that size is allocated.
  std::vector<std::uint8_t> rgbe;
  rgbe.reserve(std::min(total * 4, c.left() * 4));
  for (int i = 0; i < l.scanlines; ++i) {
    if (auto r = read_scanline(c, line.data(), l.scan_length, i); !r) return r.error();
    rgbe.insert(rgbe.end(), line.begin(), line.end());
  }
  Image img(l.width, l.height);
  for (int i = 0; i < l.scanlines; ++i)
    for (int j = 0; j < l.scan_length; ++j) {
      const int si = l.scan_forward ? i : l.scanlines - 1 - i, pj = l.pixel_forward ? j : l.scan_length - 1 - j;
      const int row = l.scan_is_y ? si : pj, col = l.scan_is_y ? pj : si;
      const std::uint8_t* p = rgbe.data() + (static_cast<std::size_t>(i) * l.scan_length + j) * 4;
      float* o = img.px(col, row);
      for (int k = 0; k < 3; ++k) o[k] = decode_channel(p[k], p[3]);
      o[3] = 1.0f;
    }
  return img;
}

}  // namespace

Result<RadianceImage> read_radiance_hdr_memory(std::span<const std::uint8_t> bytes) {
  Cursor c(bytes);
  auto header = read_header(c);
  if (!header) return header.error();
  auto layout = read_layout(c);
  if (!layout) return layout.error();
  auto img = decode_pixels(c, *layout);
  if (!img) return img.error();
  RadianceImage out;
  out.xyz = header->xyz;
  out.exposure = header->exposure;
  out.primaries = header->primaries;
  out.warnings = std::move(header->warnings);
  if (c.left() > 0) out.warnings.push_back(fmt::format("{} bytes after the last scanline ignored", c.left()));
  // EXPOSURE and COLORCORR record multipliers applied to the pixels: undo them.
  const std::array<double, 3> gain{1 / (header->exposure * header->colorcorr[0]),
                                   1 / (header->exposure * header->colorcorr[1]),
                                   1 / (header->exposure * header->colorcorr[2])};
  if (gain != std::array<double, 3>{1, 1, 1})
    for (std::size_t i = 0; i < img->pixel_count(); ++i)
      for (int k = 0; k < 3; ++k) {
        float& v = img->rgba[i * 4 + k];
        v = static_cast<float>(v * gain[k]);
        if (!std::isfinite(v))
          return hdr_error("exposure", fmt::format("EXPOSURE {} makes pixel values overflow float", header->exposure));
      }
  out.image = std::move(*img);
  return out;
}

Result<RadianceImage> read_radiance_hdr(const std::filesystem::path& path, const io::InputFiles& files) {
  auto file = files.read(path, kMaxFileBytes);
  if (!file && file.error().code == "file.too_large") return hdr_error("file", fmt::format("'{}' is larger than 4 GiB", path.string()));
  if (!file) return io::reader_error(file.error(), "hdr.file", "hdr.file", "environment.file");
  const std::span bytes(reinterpret_cast<const std::uint8_t*>(file->data()), file->size());
  auto r = read_radiance_hdr_memory(bytes);
  if (!r) return make_error(r.error().code, fmt::format("{}: {}", path.filename().string(), r.error().message),
                            r.error().field);
  return r;
}

}  // namespace hdrd::shading

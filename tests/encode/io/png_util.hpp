// A tiny PNG toolkit for the tests, independent of libpng and of hdrd's PNG code: the
// chunk stream, CRC-32 (PNG 3rd edition Annex D), a minimal encoder for crafting inputs
// and a decoder (zlib inflate + the five filters, §9) for checking hdrd's output.
#pragma once

#include <array>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include <zlib.h>

namespace hdrd::io::pngtest {

inline std::uint32_t crc32_png(const std::uint8_t* p, std::size_t n, std::uint32_t crc = 0xffffffffu) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ p[i]) & 0xff] ^ (crc >> 8);
  return crc;
}

inline std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}
inline void put_be32(std::vector<std::uint8_t>& v, std::uint32_t x) {
  for (int s = 24; s >= 0; s -= 8) v.push_back(static_cast<std::uint8_t>(x >> s));
}

struct Chunk {
  std::string type;
  std::vector<std::uint8_t> data;
  bool crc_ok = false;
};

constexpr std::array<std::uint8_t, 8> kSignature{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

// Splits a PNG into its chunks, checking each CRC over type + data.
inline std::vector<Chunk> chunks_of(const std::vector<std::uint8_t>& png) {
  if (png.size() < 8 || std::memcmp(png.data(), kSignature.data(), 8) != 0) throw std::runtime_error("no PNG signature");
  std::vector<Chunk> out;
  std::size_t pos = 8;
  while (pos + 12 <= png.size()) {
    const std::uint32_t len = be32(&png[pos]);
    if (pos + 12 + len > png.size()) throw std::runtime_error("chunk runs past the end");
    Chunk c;
    c.type.assign(reinterpret_cast<const char*>(&png[pos + 4]), 4);
    c.data.assign(png.begin() + static_cast<long>(pos + 8), png.begin() + static_cast<long>(pos + 8 + len));
    c.crc_ok = be32(&png[pos + 8 + len]) == (crc32_png(&png[pos + 4], 4 + len) ^ 0xffffffffu);
    out.push_back(std::move(c));
    pos += 12 + len;
  }
  return out;
}

inline void append_chunk(std::vector<std::uint8_t>& png, const std::string& type, const std::vector<std::uint8_t>& data) {
  put_be32(png, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = png.size();
  png.insert(png.end(), type.begin(), type.end());
  png.insert(png.end(), data.begin(), data.end());
  put_be32(png, crc32_png(&png[start], png.size() - start) ^ 0xffffffffu);
}

inline std::vector<std::uint8_t> zlib_compress(const std::vector<std::uint8_t>& raw) {
  uLongf n = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> out(n);
  if (compress2(out.data(), &n, raw.data(), static_cast<uLong>(raw.size()), 9) != Z_OK) throw std::runtime_error("zlib");
  out.resize(n);
  return out;
}

struct Spec {
  int width = 1, height = 1, bit_depth = 8, color_type = 2;
  bool adam7 = false;  // only for bit depths >= 8
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> before_idat;  // PLTE, tRNS, ...
};

inline int channels_of(int color_type) {
  switch (color_type) {
    case 0: return 1;
    case 2: return 3;
    case 3: return 1;
    case 4: return 2;
    case 6: return 4;
  }
  throw std::runtime_error("bad colour type");
}

// `rows`: the packed scanlines without filter bytes, height x ceil(width * bits per pixel / 8).
inline std::vector<std::uint8_t> encode(const Spec& s, const std::vector<std::uint8_t>& rows) {
  const std::size_t bpp_bits = static_cast<std::size_t>(channels_of(s.color_type)) * s.bit_depth;
  const std::size_t row_bytes = (s.width * bpp_bits + 7) / 8;
  std::vector<std::uint8_t> filtered;
  if (!s.adam7) {
    for (int y = 0; y < s.height; ++y) {
      filtered.push_back(0);
      filtered.insert(filtered.end(), rows.begin() + static_cast<long>(y * row_bytes),
                      rows.begin() + static_cast<long>((y + 1) * row_bytes));
    }
  } else {  // PNG §8.2 Adam7 passes
    const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, y0[7] = {0, 0, 4, 0, 2, 0, 1};
    const int dx[7] = {8, 8, 4, 4, 2, 2, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
    const std::size_t px_bytes = bpp_bits / 8;
    for (int p = 0; p < 7; ++p) {
      if (x0[p] >= s.width) continue;
      for (int y = y0[p]; y < s.height; y += dy[p]) {
        filtered.push_back(0);
        for (int x = x0[p]; x < s.width; x += dx[p])
          for (std::size_t b = 0; b < px_bytes; ++b) filtered.push_back(rows[y * row_bytes + x * px_bytes + b]);
      }
    }
  }
  std::vector<std::uint8_t> png(kSignature.begin(), kSignature.end());
  std::vector<std::uint8_t> ihdr;
  put_be32(ihdr, static_cast<std::uint32_t>(s.width));
  put_be32(ihdr, static_cast<std::uint32_t>(s.height));
  ihdr.insert(ihdr.end(), {static_cast<std::uint8_t>(s.bit_depth), static_cast<std::uint8_t>(s.color_type), 0, 0,
                           static_cast<std::uint8_t>(s.adam7 ? 1 : 0)});
  append_chunk(png, "IHDR", ihdr);
  for (const auto& [type, data] : s.before_idat) append_chunk(png, type, data);
  append_chunk(png, "IDAT", zlib_compress(filtered));
  append_chunk(png, "IEND", {});
  return png;
}

// Decodes a non-interlaced 8- or 16-bit RGB PNG into samples (PNG §9.2 filters).
struct Decoded {
  int width = 0, height = 0, bit_depth = 0, color_type = 0;
  std::vector<std::uint16_t> samples;
};

inline std::uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return static_cast<std::uint8_t>(pa <= pb && pa <= pc ? a : (pb <= pc ? b : c));
}

inline Decoded decode_rgb(const std::vector<std::uint8_t>& png) {
  Decoded d;
  std::vector<std::uint8_t> z;
  for (const Chunk& c : chunks_of(png)) {
    if (c.type == "IHDR") {
      d.width = static_cast<int>(be32(&c.data[0]));
      d.height = static_cast<int>(be32(&c.data[4]));
      d.bit_depth = c.data[8];
      d.color_type = c.data[9];
      if (c.data[12] != 0 || d.color_type != 2) throw std::runtime_error("decode_rgb: only non-interlaced RGB");
    } else if (c.type == "IDAT") {
      z.insert(z.end(), c.data.begin(), c.data.end());
    }
  }
  const std::size_t bpp = 3 * static_cast<std::size_t>(d.bit_depth) / 8, row = bpp * d.width;
  std::vector<std::uint8_t> raw((row + 1) * d.height);
  uLongf n = static_cast<uLongf>(raw.size());
  if (uncompress(raw.data(), &n, z.data(), static_cast<uLong>(z.size())) != Z_OK || n != raw.size())
    throw std::runtime_error("inflate failed");
  std::vector<std::uint8_t> prev(row, 0), cur(row);
  for (int y = 0; y < d.height; ++y) {
    const std::uint8_t* f = &raw[y * (row + 1)];
    for (std::size_t i = 0; i < row; ++i) {
      const int a = i >= bpp ? cur[i - bpp] : 0, b = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
      const int pred = f[0] == 0 ? 0 : f[0] == 1 ? a : f[0] == 2 ? b : f[0] == 3 ? (a + b) / 2 : paeth(a, b, c);
      cur[i] = static_cast<std::uint8_t>(f[1 + i] + pred);
    }
    for (std::size_t i = 0; i < row; i += d.bit_depth / 8)
      d.samples.push_back(d.bit_depth == 16 ? static_cast<std::uint16_t>((cur[i] << 8) | cur[i + 1]) : cur[i]);
    prev = cur;
  }
  return d;
}

}  // namespace hdrd::io::pngtest

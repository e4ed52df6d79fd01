// The pieces of io/zlib_stream.hpp against zlib itself: header check bits (RFC 1950 §2.2),
// Adler-32 and its combination against zlib's one-pass adler32, and segments deflated on
// their own inflating, with zlib's uncompress (which checks the trailer), as one stream.
#include <vector>

#include <gtest/gtest.h>
#include <zlib.h>

#include "encode/io/zlib_stream.hpp"

namespace hdrd::io {
namespace {

using Bytes = std::vector<std::uint8_t>;

// The zlib stream pieces on their own: header check bits, and Adler-32 combining against
// zlib's one-pass adler32 (RFC 1950 §8.2).
TEST(ZlibStream, HeaderAndAdlerCombine) {
  for (int level = detail::kMinDeflateLevel; level <= detail::kMaxDeflateLevel; ++level) {
    const auto h = detail::zlib_header(level);
    EXPECT_EQ(h[0], 0x78);
    EXPECT_EQ((h[0] * 256 + h[1]) % 31, 0) << level;
    EXPECT_EQ(h[1] & 0x20, 0) << "no preset dictionary";
  }
  Bytes data(300000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>((i * 2654435761u) >> 13);
  const std::uint32_t whole = static_cast<std::uint32_t>(::adler32(1, data.data(), static_cast<uInt>(data.size())));
  EXPECT_EQ(detail::adler32(data), whole);
  for (std::size_t cut : {std::size_t{0}, std::size_t{1}, std::size_t{5552}, std::size_t{123457}, data.size()}) {
    const std::span<const std::uint8_t> all(data);
    EXPECT_EQ(detail::adler32_combine(detail::adler32(all.first(cut)), detail::adler32(all.subspan(cut)), data.size() - cut),
              whole)
        << cut;
  }
}

// Segments deflated one by one, each with the previous bytes as its dictionary, inflate as
// one stream, at every level, including empty and one-byte segments.
TEST(ZlibStream, SegmentsInflateAsOneStream) {
  Bytes data(200000);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>((i / 7) ^ (i % 251 == 0 ? 0xa5 : 0));
  const std::vector<std::size_t> cuts{0, 1, 1, 70000, 70001, 150000, data.size()};  // empty segment at [1, 1)
  for (int level = detail::kMinDeflateLevel; level <= detail::kMaxDeflateLevel; ++level) {
    const auto header = detail::zlib_header(level);
    Bytes stream(header.begin(), header.end());
    detail::SegmentDeflater d(level);
    std::uint32_t adler = 1;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
      const std::span<const std::uint8_t> all(data);
      const auto piece = all.subspan(cuts[i], cuts[i + 1] - cuts[i]);
      ASSERT_TRUE(d.deflate(all.first(cuts[i]), piece, i + 2 == cuts.size(), stream).ok());
      adler = detail::adler32_combine(adler, detail::adler32(piece), piece.size());
    }
    for (int s = 24; s >= 0; s -= 8) stream.push_back(static_cast<std::uint8_t>(adler >> s));
    Bytes back(data.size());
    uLongf n = static_cast<uLongf>(back.size());
    ASSERT_EQ(uncompress(back.data(), &n, stream.data(), static_cast<uLong>(stream.size())), Z_OK) << level;
    EXPECT_EQ(n, data.size());
    EXPECT_EQ(back, data) << level;
  }
}

}  // namespace
}  // namespace hdrd::io

// One zlib stream (RFC 1950) compressed in independent segments on several threads, as
// pigz does: each segment is raw deflate (RFC 1951) primed with the 32 KiB that precede it
// (so matches still reach back across the cut), ended by a sync flush (an empty stored
// block, which leaves the stream on a byte boundary) except the last, which carries the
// final block; the segments' Adler-32s combine into the stream's trailer. Concatenated, the
// segments are one ordinary zlib stream that any inflater reads.
//
// Levels: 0 stores (zlib); 1-3 are ISA-L's igzip levels 1-3 (Debian's libisal: 3-7x the
// speed of zlib's level 1 on 16-bit image rows, and a slightly smaller result;
// docs/performance.md "Frame I/O"); 4-9 deflate each segment with zlib's level 4-9 and
// with ISA-L's level 3 and keep the smaller (never larger than level 3, much slower).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::io::detail {

inline constexpr int kMinDeflateLevel = 0;
inline constexpr int kMaxDeflateLevel = 9;
inline constexpr std::size_t kDeflateWindowBytes = 32768;  // RFC 1951 §2: distances reach 32 KiB back

// The two header bytes of a zlib stream with a 32 KiB window: CMF 0x78 and FLG with
// FLEVEL for `level` and FCHECK so that CMF*256 + FLG is a multiple of 31 (RFC 1950 §2.2).
std::array<std::uint8_t, 2> zlib_header(int level);

std::uint32_t adler32(std::span<const std::uint8_t> bytes, std::uint32_t adler = 1);
// Adler-32 of A followed by B, from adler32(A), adler32(B) and B's length.
std::uint32_t adler32_combine(std::uint32_t a, std::uint32_t b, std::size_t b_bytes);

// A compressor for one segment at a time, reused for the next (one per thread).
class SegmentDeflater {
 public:
  explicit SegmentDeflater(int level);  // level in [kMinDeflateLevel, kMaxDeflateLevel]
  ~SegmentDeflater();
  SegmentDeflater(const SegmentDeflater&) = delete;
  SegmentDeflater& operator=(const SegmentDeflater&) = delete;

  // Appends `data` deflated to `out`: primed with the end of `dictionary` (the bytes just
  // before `data` in the stream; empty for the first segment), ended by a sync flush, or
  // by the stream's final block when `last`.
  Result<void> deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data, bool last,
                       std::vector<std::uint8_t>& out);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace hdrd::io::detail

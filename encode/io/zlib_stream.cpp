// Segment deflaters for io/zlib_stream.hpp: zlib for stored, ISA-L (igzip) for the fast
// levels, the smaller of zlib and ISA-L for the small-file levels.
#include "encode/io/zlib_stream.hpp"

#include <algorithm>
#include <limits>

#include <fmt/format.h>
#include <isa-l/igzip_lib.h>
#include <zlib.h>

namespace hdrd::io::detail {

std::array<std::uint8_t, 2> zlib_header(int level) {
  // RFC 1950 §2.2: CM 8 (deflate), CINFO 7 (32 KiB window); FLEVEL 0 fastest .. 3 slowest.
  constexpr std::uint8_t cmf = 0x78;
  const int flevel = level <= 1 ? 0 : level <= 5 ? 1 : level == 6 ? 2 : 3;
  std::uint8_t flg = static_cast<std::uint8_t>(flevel << 6);
  flg = static_cast<std::uint8_t>(flg + (31 - (cmf * 256 + flg) % 31) % 31);
  return {cmf, flg};
}

std::uint32_t adler32(std::span<const std::uint8_t> bytes, std::uint32_t adler) {
  // ISA-L's Adler-32 is SIMD (~3x zlib's here); zlib's takes a uInt length.
  std::size_t done = 0;
  while (done < bytes.size()) {
    const auto n = static_cast<std::uint32_t>(std::min<std::size_t>(bytes.size() - done, 1u << 30));
    adler = isal_adler32(adler, bytes.data() + done, n);
    done += n;
  }
  return adler;
}

std::uint32_t adler32_combine(std::uint32_t a, std::uint32_t b, std::size_t b_bytes) {
  return static_cast<std::uint32_t>(::adler32_combine64(a, b, static_cast<z_off64_t>(b_bytes)));
}

struct SegmentDeflater::Impl {
  virtual ~Impl() = default;
  virtual Result<void> deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data,
                               bool last, std::vector<std::uint8_t>& out) = 0;
};

namespace {

std::span<const std::uint8_t> window_of(std::span<const std::uint8_t> dictionary) {
  return dictionary.size() > kDeflateWindowBytes ? dictionary.last(kDeflateWindowBytes) : dictionary;
}

// Room for a segment: deflate's stored-block worst case (5 bytes per 16 KiB block, RFC 1951
// §3.2.4) plus block headers and the flush; grown if a library still runs out.
std::size_t room_for(std::size_t n) { return n + n / 16 + 1024; }

class IsalDeflater final : public SegmentDeflater::Impl {
 public:
  explicit IsalDeflater(int level) : level_(level) {
    const std::size_t sizes[] = {0, ISAL_DEF_LVL1_DEFAULT, ISAL_DEF_LVL2_DEFAULT, ISAL_DEF_LVL3_DEFAULT};
    level_buf_.resize(sizes[level]);
  }

  Result<void> deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data, bool last,
                       std::vector<std::uint8_t>& out) override {
    isal_zstream s{};
    isal_deflate_init(&s);
    s.level = static_cast<std::uint32_t>(level_);
    s.level_buf = level_buf_.data();
    s.level_buf_size = static_cast<std::uint32_t>(level_buf_.size());
    s.gzip_flag = IGZIP_DEFLATE;  // raw deflate: the caller writes the zlib header and trailer
    s.flush = last ? NO_FLUSH : SYNC_FLUSH;
    s.end_of_stream = last ? 1 : 0;
    const auto window = window_of(dictionary);
    if (!window.empty() &&
        isal_deflate_set_dict(&s, const_cast<std::uint8_t*>(window.data()), static_cast<std::uint32_t>(window.size())) !=
            COMP_OK)
      return make_error("deflate.internal", "ISA-L refused the segment dictionary");
    std::size_t in_done = 0;
    const std::size_t start = out.size();
    out.resize(start + room_for(data.size()));
    s.next_out = out.data() + start;
    s.avail_out = static_cast<std::uint32_t>(std::min<std::size_t>(out.size() - start, UINT32_MAX));
    while (true) {
      if (s.avail_in == 0 && in_done < data.size()) {
        const std::size_t n = std::min<std::size_t>(data.size() - in_done, 1u << 30);
        s.next_in = const_cast<std::uint8_t*>(data.data() + in_done);
        s.avail_in = static_cast<std::uint32_t>(n);
        in_done += n;
      }
      const std::uint8_t* out_before = s.next_out;
      const std::uint32_t in_before = s.avail_in;
      if (const int rc = isal_deflate(&s); rc != COMP_OK)
        return make_error("deflate.internal", fmt::format("ISA-L deflate failed ({})", rc));
      const bool flushed = last ? s.internal_state.state == ZSTATE_END : s.internal_state.state == ZSTATE_NEW_HDR;
      if (s.avail_in == 0 && in_done == data.size() && flushed) break;
      if (s.avail_out != 0 && s.next_out == out_before && s.avail_in == in_before)
        return make_error("deflate.internal", "ISA-L deflate made no progress");
      if (s.avail_out == 0) {  // grow and go on where it stopped
        const std::size_t used = static_cast<std::size_t>(s.next_out - out.data());
        out.resize(out.size() + room_for(data.size() / 4));
        s.next_out = out.data() + used;
        s.avail_out = static_cast<std::uint32_t>(std::min<std::size_t>(out.size() - used, UINT32_MAX));
      }
    }
    out.resize(static_cast<std::size_t>(s.next_out - out.data()));
    return {};
  }

 private:
  int level_;
  std::vector<std::uint8_t> level_buf_;
};

class ZlibDeflater final : public SegmentDeflater::Impl {
 public:
  explicit ZlibDeflater(int level) {
    // Raw deflate (negative window bits), 32 KiB window, zlib's default memory level.
    ok_ = deflateInit2(&z_, level, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) == Z_OK;
  }
  ~ZlibDeflater() override {
    if (ok_) deflateEnd(&z_);
  }

  Result<void> deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data, bool last,
                       std::vector<std::uint8_t>& out) override {
    if (!ok_ || deflateReset(&z_) != Z_OK) return make_error("deflate.internal", "zlib deflateInit2 failed");
    const auto window = window_of(dictionary);
    if (!window.empty() &&
        deflateSetDictionary(&z_, window.data(), static_cast<uInt>(window.size())) != Z_OK)
      return make_error("deflate.internal", "zlib refused the segment dictionary");
    const std::size_t start = out.size();
    out.resize(start + room_for(data.size()));
    z_.next_out = out.data() + start;
    z_.avail_out = static_cast<uInt>(std::min<std::size_t>(out.size() - start, UINT32_MAX));
    std::size_t in_done = 0;
    while (true) {
      if (z_.avail_in == 0 && in_done < data.size()) {
        const std::size_t n = std::min<std::size_t>(data.size() - in_done, 1u << 30);
        z_.next_in = const_cast<Bytef*>(data.data() + in_done);
        z_.avail_in = static_cast<uInt>(n);
        in_done += n;
      }
      const bool all_in = in_done == data.size();
      const int rc = ::deflate(&z_, all_in ? (last ? Z_FINISH : Z_SYNC_FLUSH) : Z_NO_FLUSH);
      if (rc == Z_STREAM_ERROR || (rc == Z_BUF_ERROR && z_.avail_out != 0))
        return make_error("deflate.internal", "zlib deflate failed");
      // Done when the stream ended, or when a sync flush left room over (zlib's manual:
      // a flush is complete once deflate returns with avail_out != 0).
      if (all_in && (last ? rc == Z_STREAM_END : z_.avail_in == 0 && z_.avail_out != 0)) break;
      if (z_.avail_out == 0) {
        const std::size_t used = static_cast<std::size_t>(z_.next_out - out.data());
        out.resize(out.size() + room_for(data.size() / 4));
        z_.next_out = out.data() + used;
        z_.avail_out = static_cast<uInt>(std::min<std::size_t>(out.size() - used, UINT32_MAX));
      }
    }
    out.resize(static_cast<std::size_t>(z_.next_out - out.data()));
    return {};
  }

 private:
  z_stream z_{};
  bool ok_ = false;
};

// The small-file levels: zlib's level and ISA-L's best, the smaller segment kept. On
// photographic 16-bit lines ISA-L's Huffman coding beats zlib's at every level; on flat or
// synthetic content (patterns, UI, ramps) zlib's longer match search wins.
class SmallerOfDeflater final : public SegmentDeflater::Impl {
 public:
  explicit SmallerOfDeflater(int level) : zlib_(level), isal_(ISAL_DEF_MAX_LEVEL) {}

  Result<void> deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data, bool last,
                       std::vector<std::uint8_t>& out) override {
    other_.clear();
    if (auto ok = isal_.deflate(dictionary, data, last, other_); !ok) return ok;
    const std::size_t start = out.size();
    if (auto ok = zlib_.deflate(dictionary, data, last, out); !ok) return ok;
    if (other_.size() < out.size() - start) {
      out.resize(start);
      out.insert(out.end(), other_.begin(), other_.end());
    }
    return {};
  }

 private:
  ZlibDeflater zlib_;
  IsalDeflater isal_;
  std::vector<std::uint8_t> other_;
};

}  // namespace

SegmentDeflater::SegmentDeflater(int level) {
  level = std::clamp(level, kMinDeflateLevel, kMaxDeflateLevel);
  if (level == 0) impl_ = std::make_unique<ZlibDeflater>(0);
  else if (level <= ISAL_DEF_MAX_LEVEL) impl_ = std::make_unique<IsalDeflater>(level);
  else impl_ = std::make_unique<SmallerOfDeflater>(level);
}

SegmentDeflater::~SegmentDeflater() = default;

Result<void> SegmentDeflater::deflate(std::span<const std::uint8_t> dictionary, std::span<const std::uint8_t> data,
                                      bool last, std::vector<std::uint8_t>& out) {
  return impl_->deflate(dictionary, data, last, out);
}

}  // namespace hdrd::io::detail

#include "encode/kernel/float_lut.hpp"

#include <limits>

namespace hdrd {

FloatBitsLut::FloatBitsLut(const std::function<double(double)>& f, int min_exp2, int max_exp2,
                           std::span<const double> kinks) {
  lo_ = std::ldexp(1.0f, min_exp2);
  hi_ = std::ldexp(1.0f, max_exp2);
  base_bits_ = std::bit_cast<std::uint32_t>(lo_);
  const std::size_t n = (static_cast<std::size_t>(max_exp2 - min_exp2) << kBitsPerOctave) + 1;
  table_.resize(n + 1);
  for (std::size_t i = 0; i <= n; ++i) {
    const float v = std::bit_cast<float>(base_bits_ + static_cast<std::uint32_t>(i << kShift));
    table_[i] = static_cast<float>(f(static_cast<double>(i < n ? v : hi_)));
  }
  pairs_.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    pairs_[2 * i] = table_[i];
    pairs_[2 * i + 1] = table_[i + 1] - table_[i];
  }
  add_patches(f, kinks);
  // Buckets 0 .. j - 1 hold table_[0] at both ends (a zero step) and no patch: flat up to bucket j.
  std::size_t j = 0;
  auto patched = [&](std::size_t b) {
    return std::any_of(patches_.begin(), patches_.end(), [&](const Patch& p) { return p.bucket == b; });
  };
  while (j < n && table_[j + 1] == table_[0] && !patched(j)) ++j;
  if (j > 0) flat_below_ = j < n ? std::bit_cast<float>(base_bits_ + static_cast<std::uint32_t>(j << kShift)) : hi_;
}

void FloatBitsLut::add_patches(const std::function<double(double)>& f, std::span<const double> kinks) {
  constexpr std::uint32_t kMask = (1u << kShift) - 1;
  constexpr float kStep = 1.0f / (1u << kShift);
  // The kinks inside the table, as the float the lookup sees, by bucket and position.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> at;  // (bucket, position in it)
  for (double k : kinks) {
    const float v = static_cast<float>(k);
    if (!(v > lo_ && v < hi_)) continue;
    const std::uint32_t rel = std::bit_cast<std::uint32_t>(v) - base_bits_;
    if ((rel & kMask) != 0) at.emplace_back(rel >> kShift, rel & kMask);
  }
  std::sort(at.begin(), at.end());
  at.erase(std::unique(at.begin(), at.end()), at.end());
  if (at.size() > kMaxPatches) at.resize(kMaxPatches);
  for (std::size_t i = 0; i < at.size(); ++i) {
    const auto [bucket, pos] = at[i];
    Patch p;
    p.bucket = bucket;
    p.at = static_cast<float>(pos) * kStep;
    p.left = i > 0 && at[i - 1].first == bucket ? static_cast<float>(at[i - 1].second) * kStep : 0.0f;
    p.right = i + 1 < at.size() && at[i + 1].first == bucket ? static_cast<float>(at[i + 1].second) * kStep : 1.0f;
    p.inv_left = 1.0f / (p.at - p.left);
    p.inv_right = 1.0f / (p.right - p.at);
    // In the nodal basis of the bucket's nodes, the interpolant through every node is the
    // straight line plus, per kink, (f(kink) - line(kink)) times the kink's hat.
    const float x = std::bit_cast<float>(base_bits_ + (bucket << kShift) + pos);
    const double line = table_[bucket] + (static_cast<double>(table_[bucket + 1]) - table_[bucket]) * p.at;
    p.delta = static_cast<float>(f(static_cast<double>(x)) - line);
    patches_.push_back(p);
  }
}

FloatBitsQuantizer::FloatBitsQuantizer(const std::function<int(double)>& code, int min_exp2, int max_exp2) {
  const std::uint32_t lo_bits = std::bit_cast<std::uint32_t>(std::ldexp(1.0f, min_exp2));
  const std::uint32_t hi_bits = std::bit_cast<std::uint32_t>(std::ldexp(1.0f, max_exp2)) - 1;  // largest float below
  auto code_at = [&](std::uint32_t bits) { return code(static_cast<double>(std::bit_cast<float>(bits))); };
  const int first = code_at(lo_bits), last = code_at(hi_bits);
  if (code(0.0) != first || code(static_cast<double>(std::numeric_limits<float>::max())) != last || last < first ||
      last > kMaxCode)
    return;
  // Where each code starts: the smallest float (as bits; positive floats order as their
  // bits) whose code reaches it.
  std::vector<std::uint32_t> starts;
  starts.reserve(static_cast<std::size_t>(last - first));
  std::uint32_t from = lo_bits;
  for (int c = first + 1; c <= last; ++c) {
    std::uint32_t a = from, b = hi_bits;  // code_at(a) < c <= code_at(b)
    while (b - a > 1) {
      const std::uint32_t m = a + (b - a) / 2;
      (code_at(m) >= c ? b : a) = m;
    }
    if (code_at(b) > c) return;  // a code no float reaches: not tabulable this way
    starts.push_back(b);
    from = b;
  }
  for (int bits_per_octave = 7; bits_per_octave <= 11; ++bits_per_octave) {
    const int shift = 23 - bits_per_octave;
    bool one_per_bucket = true;
    for (std::size_t i = 1; i < starts.size() && one_per_bucket; ++i)
      one_per_bucket = ((starts[i] - lo_bits) >> shift) != ((starts[i - 1] - lo_bits) >> shift);
    if (!one_per_bucket) continue;
    shift_ = shift;
    base_bits_ = lo_bits;
    top_rel_ = hi_bits - lo_bits;
    table_.assign((top_rel_ >> shift) + 1, 0);
    std::size_t next = 0;  // the first code start not before the current bucket
    for (std::size_t i = 0; i < table_.size(); ++i) {
      const std::uint32_t begin = lo_bits + static_cast<std::uint32_t>(i << shift);
      while (next < starts.size() && starts[next] <= begin) ++next;
      const std::uint32_t c0 = static_cast<std::uint32_t>(first) + static_cast<std::uint32_t>(next);
      // The last position with code c0: just before the next code's start (>= 1 past the
      // bucket start), or the bucket's end.
      std::uint32_t last_low = (1u << shift) - 1;
      if (next < starts.size() && starts[next] - begin < (1u << shift)) last_low = starts[next] - begin - 1;
      table_[i] = c0 | (last_low << (32 - shift));
    }
    return;
  }
}

}  // namespace hdrd

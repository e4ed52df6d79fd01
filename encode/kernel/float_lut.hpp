// A function of a positive float tabulated on a grid uniform in log2 (2^kBitsPerOctave
// points per octave), indexed straight from the float's bit pattern and interpolated
// linearly inside each bucket (the mantissa is linear in the value there). Smooth
// transfer and tone functions reproduce to ~1e-8 with 128 points per octave, at the cost
// of a shift, a subtract and two loads: this is how the fast encode path evaluates PQ,
// sRGB, BT.1886, HLG and baked tone curves.
//
// A kink (where the function's slope jumps: a clamp at a peak, a curve's white point, a
// black level) inside a bucket would be interpolated across and missed by up to a quarter
// of the slope jump times the bucket width (BT.2390's corner at the source peak came out
// 11 16-bit PNG steps low). The kinks a function declares become nodes of their own: the
// bucket's straight line plus a hat function through the kink's value ("patches"), so
// each side of a kink interpolates only its own side.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace hdrd {

class FloatBitsLut {
 public:
  static constexpr int kBitsPerOctave = 7;
  static constexpr int kShift = 23 - kBitsPerOctave;

  // A kink inside bucket `bucket`: the lookup adds delta x hat(frac), the hat rising from
  // `left` to 1 at `at` and falling to 0 at `right` (its neighbouring nodes: the bucket's
  // ends or other kinks in it), delta = f(kink) - the bucket's straight line at `at`.
  // Positions are the lookup's fraction inside the bucket (multiples of 2^-kShift).
  struct Patch {
    std::uint32_t bucket = 0;
    float left = 0, at = 0, right = 1;
    float inv_left = 1, inv_right = 1;  // 1 / (at - left), 1 / (right - at)
    float delta = 0;
    float hat(float frac) const {
      return std::max(0.0f, std::min((frac - left) * inv_left, (right - frac) * inv_right));
    }
  };
  static constexpr std::size_t kMaxPatches = 8;

  FloatBitsLut() = default;
  // Tabulates f on [2^min_exp2, 2^max_exp2], with a node on each of `kinks` inside that
  // range (at most kMaxPatches; a kink that falls on a bucket's end needs none).
  FloatBitsLut(const std::function<double(double)>& f, int min_exp2, int max_exp2,
               std::span<const double> kinks = {});

  // Below the range: the value at the bottom; above: the value at the top.
  float operator()(float v) const {
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
    if (!(v > lo_)) return table_.front();
    if (v >= hi_) return table_.back();
    const std::uint32_t rel = bits - base_bits_;
    const std::uint32_t i = rel >> kShift;
    const float frac = static_cast<float>(rel & ((1u << kShift) - 1)) * (1.0f / (1u << kShift));
    const float a = table_[i], b = table_[i + 1];
    float r = a + (b - a) * frac;
    for (const Patch& p : patches_)
      if (p.bucket == i) r += p.delta * p.hat(frac);
    return r;
  }

  float lo() const { return lo_; }
  float hi() const { return hi_; }
  const std::vector<float>& table() const { return table_; }
  // The table as (value, next value - value) pairs, 8 bytes per bucket: one 64-bit gather
  // fetches both ends of a bucket (SIMD code).
  const std::vector<float>& pairs() const { return pairs_; }
  std::uint32_t base_bits() const { return base_bits_; }
  // Where the table is flat from its bottom: every v < flat_below() (negative values and
  // those below lo() included) looks up exactly table().front(), with no interpolation
  // step. 0 when the first bucket already slopes. A curve that is linear below a knee
  // (a ratio table that is constant there) lets SIMD code skip the lookup below it. It
  // ends at the first patched bucket too.
  float flat_below() const { return flat_below_; }
  const std::vector<Patch>& patches() const { return patches_; }

 private:
  void add_patches(const std::function<double(double)>& f, std::span<const double> kinks);
  std::vector<float> table_;
  std::vector<float> pairs_;
  std::vector<Patch> patches_;
  std::uint32_t base_bits_ = 0;
  float lo_ = 0, hi_ = 0;
  float flat_below_ = 0;
};

// A monotonic float -> integer code function, tabulated exactly: every bucket of the
// float's bit pattern (2^bits_per_octave per octave) holds the code at its start and, when
// the next code starts inside it, where (in bits from the bucket start). One 32-bit load,
// a shift, a compare and an add give the code the function gives for that very float: no
// interpolation, no rounding, so a signal quantised this way has no off-by-one codes
// against the double-precision reference. Used by the fast encode path for
// nits -> PQ / sRGB / BT.1886 / gamma 2.2 codes, where one code spans at least 1/78 of an
// octave (10-bit) and 128 to 512 buckets per octave hold at most one code boundary each.
//
// Entry layout, for a grid of 2^shift float bit patterns per bucket: the code at the
// bucket start in the low 32 - shift bits, and above them `last`, the last position (bits
// from the bucket start) that still has that code (2^shift - 1 when the next code does
// not start inside the bucket). A float whose position in its bucket is `low` has the next
// code exactly when low > last, that is when low << (32 - shift) > entry as unsigned
// integers: the code below cannot tip the comparison.
class FloatBitsQuantizer {
 public:
  static constexpr int kMaxCode = 0xFFFF;  // the code field is at least 16 bits (shift <= 16)

  FloatBitsQuantizer() = default;
  // code(x) must be non-decreasing on [0, inf) and at most kMaxCode. Tabulates it on
  // [2^min_exp2, 2^max_exp2) with the coarsest grid (128 to 2048 buckets per octave) that
  // keeps one boundary per bucket; empty() when none does, or when code is not constant
  // on [0, 2^min_exp2] and on [2^max_exp2, inf) (the kernel clamps into the range).
  FloatBitsQuantizer(const std::function<int(double)>& code, int min_exp2, int max_exp2);

  bool empty() const { return table_.empty(); }
  int code(float v) const {
    const std::uint32_t rel = clamp_rel(v);
    const std::uint32_t e = table_[rel >> shift_];
    return static_cast<int>(e & code_mask()) + ((rel << (32 - shift_)) > e ? 1 : 0);
  }

  const std::vector<std::uint32_t>& table() const { return table_; }
  std::uint32_t base_bits() const { return base_bits_; }
  std::uint32_t top_rel() const { return top_rel_; }  // the largest bits - base_bits looked up
  int shift() const { return shift_; }
  std::uint32_t code_mask() const { return (1u << (32 - shift_)) - 1; }

 private:
  std::uint32_t clamp_rel(float v) const {
    if (!(v > 0)) return 0;
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
    return bits <= base_bits_ ? 0 : std::min(bits - base_bits_, top_rel_);
  }
  std::vector<std::uint32_t> table_;
  std::uint32_t base_bits_ = 0, top_rel_ = 0;
  int shift_ = 0;
};

}  // namespace hdrd

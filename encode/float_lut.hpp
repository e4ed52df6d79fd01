// A function of a positive float tabulated on a grid uniform in log2 (2^kBitsPerOctave
// points per octave), indexed straight from the float's bit pattern and interpolated
// linearly inside each bucket (the mantissa is linear in the value there). Smooth
// transfer and tone functions reproduce to ~1e-8 with 128 points per octave, at the cost
// of a shift, a subtract and two loads: this is how the fast encode path evaluates PQ,
// sRGB, BT.1886, HLG and baked tone curves.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

namespace hdrd {

class FloatBitsLut {
 public:
  static constexpr int kBitsPerOctave = 7;
  static constexpr int kShift = 23 - kBitsPerOctave;

  FloatBitsLut() = default;
  // Tabulates f on [2^min_exp2, 2^max_exp2].
  FloatBitsLut(const std::function<double(double)>& f, int min_exp2, int max_exp2);

  // Below the range: the value at the bottom; above: the value at the top.
  float operator()(float v) const {
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
    if (!(v > lo_)) return table_.front();
    if (v >= hi_) return table_.back();
    const std::uint32_t rel = bits - base_bits_;
    const std::uint32_t i = rel >> kShift;
    const float frac = static_cast<float>(rel & ((1u << kShift) - 1)) * (1.0f / (1u << kShift));
    const float a = table_[i], b = table_[i + 1];
    return a + (b - a) * frac;
  }

  float lo() const { return lo_; }
  float hi() const { return hi_; }
  const std::vector<float>& table() const { return table_; }
  // The table as (value, next value - value) pairs, 8 bytes per bucket: one 64-bit gather
  // fetches both ends of a bucket (SIMD code).
  const std::vector<float>& pairs() const { return pairs_; }
  std::uint32_t base_bits() const { return base_bits_; }

 private:
  std::vector<float> table_;
  std::vector<float> pairs_;
  std::uint32_t base_bits_ = 0;
  float lo_ = 0, hi_ = 0;
};

}  // namespace hdrd

// A smooth function of a positive float as one polynomial per octave (segment = the
// float's exponent, variable = its mantissa), so that SIMD code evaluates it with a lane
// permute per coefficient and a Horner chain instead of table gathers (gathers dominate
// the fused encode kernel otherwise). Each octave interpolates the function at the
// Chebyshev-Lobatto points, end points included, so neighbouring octaves meet (continuous
// to float rounding). The constructor measures the float evaluation against the function
// over the whole range; `max_error()` says how good the fit is and the caller decides
// whether to use it (functions with kinks — a clip, a piecewise transfer — fit badly and
// keep the FloatBitsLut).
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>

namespace hdrd {

class FloatBitsPoly {
 public:
  static constexpr int kDegree = 6;
  static constexpr int kCoeffs = kDegree + 1;
  // Segments are stored top-aligned in kSlots slots per coefficient: slot = segment +
  // kSlots - segments(). SIMD code looks up 32 slots with one two-register permute.
  static constexpr int kSlots = 64;

  FloatBitsPoly() = default;
  // Fits f on [2^min_exp2, 2^max_exp2] (at most kSlots octaves). Below the range the
  // value is f(2^min_exp2), above it f(2^max_exp2), as FloatBitsLut.
  FloatBitsPoly(const std::function<double(double)>& f, int min_exp2, int max_exp2);

  bool empty() const { return segments_ == 0; }
  int segments() const { return segments_; }
  float lo() const { return lo_; }
  float hi() const { return hi_; }
  // The largest float below hi(): inputs are clamped to [lo, hi_prev].
  float hi_prev() const { return hi_prev_; }
  std::uint32_t base_bits() const { return base_bits_; }
  // coefficients()[k * kSlots + slot]: the coefficient of u^k, u = mantissa fraction - 0.5.
  const float* coefficients() const { return coef_.data(); }
  // The largest |float evaluation - f| found over the range (dense sampling of every octave).
  double max_error() const { return max_error_; }
  // The same relative to |f| (where f != 0).
  double max_relative_error() const { return max_relative_error_; }

  // The scalar evaluation, operation for operation what the SIMD kernel does.
  float operator()(float v) const {
    v = v > lo_ ? v : lo_;  // also NaN -> lo
    v = v < hi_prev_ ? v : hi_prev_;
    const std::uint32_t rel = std::bit_cast<std::uint32_t>(v) - base_bits_;
    const int slot = static_cast<int>(rel >> 23) + kSlots - segments_;
    const float u = static_cast<float>(rel & 0x7FFFFFu) * (1.0f / 8388608.0f) - 0.5f;
    const auto c = [&](int k) { return coef_[static_cast<std::size_t>(k * kSlots + slot)]; };
    // Estrin's scheme with fused multiply-adds, as the kernel evaluates it.
    static_assert(kDegree == 6);
    const float u2 = u * u;
    const float p01 = std::fma(c(1), u, c(0)), p23 = std::fma(c(3), u, c(2));
    const float p456 = std::fma(std::fma(c(6), u, c(5)), u, c(4));
    return std::fma(std::fma(p456, u2, p23), u2, p01);
  }

 private:
  std::array<float, kCoeffs * kSlots> coef_{};
  int segments_ = 0;
  std::uint32_t base_bits_ = 0;
  float lo_ = 0, hi_ = 0, hi_prev_ = 0;
  double max_error_ = 0, max_relative_error_ = 0;
};

}  // namespace hdrd

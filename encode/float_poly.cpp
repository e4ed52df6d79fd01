#include "encode/float_poly.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hdrd {
namespace {

constexpr int kN = FloatBitsPoly::kCoeffs;

// Coefficients of the polynomial through (x[j], y[j]): the Vandermonde system solved with
// partial pivoting (7x7 with nodes in [-0.5, 0.5]: well conditioned in double).
std::array<double, kN> interpolate(const std::array<double, kN>& x, const std::array<double, kN>& y) {
  double a[kN][kN + 1];
  for (int r = 0; r < kN; ++r) {
    double p = 1;
    for (int c = 0; c < kN; ++c, p *= x[r]) a[r][c] = p;
    a[r][kN] = y[r];
  }
  for (int c = 0; c < kN; ++c) {
    int piv = c;
    for (int r = c + 1; r < kN; ++r)
      if (std::abs(a[r][c]) > std::abs(a[piv][c])) piv = r;
    std::swap(a[c], a[piv]);
    for (int r = 0; r < kN; ++r) {
      if (r == c) continue;
      const double f = a[r][c] / a[c][c];
      for (int k = c; k <= kN; ++k) a[r][k] -= f * a[c][k];
    }
  }
  std::array<double, kN> out{};
  for (int r = 0; r < kN; ++r) out[r] = a[r][kN] / a[r][r];
  return out;
}

}  // namespace

FloatBitsPoly::FloatBitsPoly(const std::function<double(double)>& f, int min_exp2, int max_exp2) {
  if (max_exp2 <= min_exp2 || max_exp2 - min_exp2 > kSlots)
    throw std::invalid_argument("FloatBitsPoly: range must span 1.." + std::to_string(kSlots) + " octaves");
  segments_ = max_exp2 - min_exp2;
  lo_ = std::ldexp(1.0f, min_exp2);
  hi_ = std::ldexp(1.0f, max_exp2);
  hi_prev_ = std::nextafter(hi_, 0.0f);
  base_bits_ = std::bit_cast<std::uint32_t>(lo_);

  std::array<double, kN> nodes{};
  for (int j = 0; j < kN; ++j) nodes[j] = -0.5 * std::cos(M_PI * j / kDegree);  // Chebyshev-Lobatto
  for (int s = 0; s < segments_; ++s) {
    const double octave = std::ldexp(1.0, min_exp2 + s);
    std::array<double, kN> y{};
    for (int j = 0; j < kN; ++j) y[j] = f(octave * (1.5 + nodes[j]));
    const auto c = interpolate(nodes, y);
    const int slot = s + kSlots - segments_;
    for (int k = 0; k < kN; ++k) coef_[static_cast<std::size_t>(k * kSlots + slot)] = static_cast<float>(c[k]);
  }

  // Measure what the float evaluation does, at both ends and densely inside every octave.
  constexpr int kSamples = 1024;
  for (int s = 0; s < segments_; ++s) {
    const std::uint32_t first = base_bits_ + (static_cast<std::uint32_t>(s) << 23);
    for (int i = 0; i <= kSamples; ++i) {
      const std::uint32_t bits = first + static_cast<std::uint32_t>((static_cast<std::uint64_t>(i) << 23) / kSamples);
      const float v = std::min(std::bit_cast<float>(bits), hi_prev_);
      const double want = f(v), err = std::abs(static_cast<double>((*this)(v)) - want);
      max_error_ = std::max(max_error_, err);
      if (want != 0) max_relative_error_ = std::max(max_relative_error_, err / std::abs(want));
    }
  }
}

}  // namespace hdrd

#include "encode/float_lut.hpp"

namespace hdrd {

FloatBitsLut::FloatBitsLut(const std::function<double(double)>& f, int min_exp2, int max_exp2) {
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
}

}  // namespace hdrd

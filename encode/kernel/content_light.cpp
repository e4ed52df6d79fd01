#include <cmath>
#include <algorithm>
#include <cstring>

#include "encode/frame.hpp"
#include "encode/kernel/pipeline_internal.hpp"

namespace hdrd {

ContentLightLevel measure_content_light(const EncodedFrame& f) {
  const auto& t = f.target;
  if (t.mode != Mode::hdr10 && t.mode != Mode::hlg && t.mode != Mode::scrgb) return {};
  const auto sig_ptr = detail::cached_signal_stage(t);
  const auto& sig = *sig_ptr;
  const color::Mat3 to2020 = color::rgb_to_rgb(color::kRec709, color::kRec2020);
  double max_nits = 0, sum = 0;
  for (int y = 0; y < f.height; ++y) {
    const std::uint8_t* row = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    double row_sum = 0;
    for (int x = 0; x < f.width; ++x) {
      double m = 0;
      if (t.mode == Mode::scrgb) {
        std::uint16_t h[3];
        std::memcpy(h, row + static_cast<std::size_t>(x) * 8, 6);
        const color::Vec3 c = to2020 * color::Vec3{detail::half_to_float(h[0]) * 80.0, detail::half_to_float(h[1]) * 80.0,
                                                   detail::half_to_float(h[2]) * 80.0};
        m = std::max({c.x, c.y, c.z, 0.0});
      } else {
        std::uint32_t w;
        std::memcpy(&w, row + static_cast<std::size_t>(x) * 4, 4);
        const int c[3] = {static_cast<int>(w & 1023), static_cast<int>((w >> 10) & 1023), static_cast<int>((w >> 20) & 1023)};
        if (t.mode == Mode::hdr10) {
          m = sig.code_to_nits[static_cast<std::size_t>(std::max({c[0], c[1], c[2]}))];
        } else {
          const float e[3] = {sig.code_to_nits[c[0]], sig.code_to_nits[c[1]], sig.code_to_nits[c[2]]};
          const float ys = 0.2627f * e[0] + 0.6780f * e[1] + 0.0593f * e[2];
          m = ys > 0 ? sig.hlg_peak * std::pow(ys, sig.hlg_gamma - 1) * std::max({e[0], e[1], e[2]}) : 0.0;
        }
      }
      max_nits = std::max(max_nits, m);
      row_sum += m;
    }
    sum += row_sum;
  }
  const double n = static_cast<double>(f.width) * f.height;
  return {max_nits, n > 0 ? sum / n : 0.0};
}

}  // namespace hdrd

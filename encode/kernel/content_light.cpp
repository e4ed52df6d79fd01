// The light of an encoded frame, decoded from its codes (REFERENCE.md §6): the one place
// that turns codes back into display light for MaxCLL/MaxFALL and for the per-frame
// statistics of sequences (encode/video/sequence_metadata.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "encode/colour/transfer.hpp"
#include "encode/frame.hpp"
#include "encode/kernel/light_kernels.hpp"
#include "encode/kernel/pipeline_internal.hpp"

namespace hdrd {

namespace {

int pq_bin(double nits) {
  const double e = transfer::pq_inverse_eotf_fast(std::max(nits, 0.0));
  return std::clamp(static_cast<int>(e * (FrameLight::kPqBins - 1) + 0.5), 0, FrameLight::kPqBins - 1);
}

// HDR10: maxRGB is the light of the largest code, so a histogram of codes holds it all.
void measure_pq_codes(const EncodedFrame& f, const detail::SignalStage& sig, FrameLight& out) {
  std::array<std::uint64_t, 1024> per_code{};
  std::array<std::uint32_t, 3> max_code{};
  kernels::max_code_histogram(f.data.data(), f.width, f.height, f.stride_bytes, per_code, max_code);
  for (int c = 0; c < 3; ++c) out.max_channel_nits[static_cast<std::size_t>(c)] = sig.code_to_nits[max_code[c]];
  double sum = 0;
  bool any = false;
  for (std::size_t c = 0; c < per_code.size(); ++c) {
    if (per_code[c] == 0) continue;
    const double nits = sig.code_to_nits[c];
    if (!any) out.min_nits = nits, any = true;
    out.max_nits = nits;
    sum += nits * static_cast<double>(per_code[c]);
    out.pq_counts[static_cast<std::size_t>(pq_bin(nits))] += static_cast<std::uint32_t>(per_code[c]);
  }
  out.mean_nits = out.pixels > 0 ? sum / static_cast<double>(out.pixels) : 0.0;
}

// HLG and scRGB: light per pixel (the HLG OOTF depends on the pixel's luminance).
void measure_per_pixel(const EncodedFrame& f, const detail::SignalStage& sig, FrameLight& out) {
  const color::Mat3 to2020 = color::rgb_to_rgb(color::kRec709, color::kRec2020);
  double sum = 0, min_nits = INFINITY;
  for (int y = 0; y < f.height; ++y) {
    const std::uint8_t* row = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    for (int x = 0; x < f.width; ++x) {
      color::Vec3 c;
      if (f.target.mode == Mode::scrgb) {
        std::uint16_t h[3];
        std::memcpy(h, row + static_cast<std::size_t>(x) * 8, 6);
        c = to2020 * color::Vec3{detail::half_to_float(h[0]) * transfer::kScrgbUnitNits,
                                 detail::half_to_float(h[1]) * transfer::kScrgbUnitNits,
                                 detail::half_to_float(h[2]) * transfer::kScrgbUnitNits};
      } else {
        std::uint32_t w;
        std::memcpy(&w, row + static_cast<std::size_t>(x) * 4, 4);
        const float e[3] = {sig.code_to_nits[w & 1023], sig.code_to_nits[(w >> 10) & 1023], sig.code_to_nits[(w >> 20) & 1023]};
        const float k = detail::hlg_ootf_gain(sig, e[0], e[1], e[2]);
        c = {k * e[0], k * e[1], k * e[2]};
      }
      const double m = std::max({c.x, c.y, c.z, 0.0});
      for (int i = 0; i < 3; ++i) out.max_channel_nits[static_cast<std::size_t>(i)] = std::max(out.max_channel_nits[static_cast<std::size_t>(i)], c[i]);
      out.max_nits = std::max(out.max_nits, m);
      min_nits = std::min(min_nits, m);
      sum += m;
      ++out.pq_counts[static_cast<std::size_t>(pq_bin(m))];
    }
  }
  out.min_nits = out.pixels > 0 ? min_nits : 0.0;
  out.mean_nits = out.pixels > 0 ? sum / static_cast<double>(out.pixels) : 0.0;
}

}  // namespace

FrameLight measure_frame_light(const EncodedFrame& f) {
  FrameLight out;
  const auto& t = f.target;
  if (t.mode != Mode::hdr10 && t.mode != Mode::hlg && t.mode != Mode::scrgb) return out;
  out.pixels = static_cast<std::uint64_t>(std::max(f.width, 0)) * static_cast<std::uint64_t>(std::max(f.height, 0));
  const auto sig = detail::cached_signal_stage(t);
  if (t.mode == Mode::hdr10)
    measure_pq_codes(f, *sig, out);
  else
    measure_per_pixel(f, *sig, out);
  return out;
}

double FrameLight::percentile_nits(double p) const {
  if (pixels == 0) return 0.0;
  const double rank = std::max(1.0, std::ceil(std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(pixels)));
  std::uint64_t below = 0;
  for (int i = 0; i < kPqBins; ++i) {
    below += pq_counts[static_cast<std::size_t>(i)];
    if (static_cast<double>(below) >= rank) return transfer::pq_eotf(static_cast<double>(i) / (kPqBins - 1));
  }
  return max_nits;
}

ContentLightLevel measure_content_light(const EncodedFrame& f) {
  const FrameLight light = measure_frame_light(f);
  return {light.max_nits, light.mean_nits};
}

}  // namespace hdrd

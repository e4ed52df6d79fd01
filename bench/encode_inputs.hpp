// The encode benchmarks' inputs, shared by bench_encode and pair_encode so both time the
// same frame: 3840x2160 RGBA16F, the mode's defaults with +0.5 EV, and the UI overlay of
// the UI variant.
#pragma once

#include <cmath>
#include <cstddef>
#include <memory>
#include <random>

#include "encode/pipeline.hpp"
#include "encode/kernel/pipeline_internal.hpp"

namespace hdrd::bench {

inline constexpr int kW = 3840, kH = 2160;

// A deterministic scene-like frame: smooth gradients over ~14 stops plus noise,
// Rec.709 relative values (1.0 = diffuse white), a few specular highlights.
inline const ImageHalf& frame_half() {
  static const ImageHalf img = [] {
    ImageHalf h(kW, kH);
    std::mt19937 rng(42);
    std::normal_distribution<float> noise(0, 0.15f);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const float base = -9.0f + 14.0f * x / kW + 2.0f * std::sin(y * 0.01f);
        const std::size_t i = (static_cast<std::size_t>(y) * kW + x) * 4;
        const float c[3] = {std::exp2(base + noise(rng)), std::exp2(base - 0.5f + noise(rng)),
                            std::exp2(base - 1.0f + noise(rng))};
        for (int k = 0; k < 3; ++k) h.rgba[i + k] = detail::float_to_half(c[k]);
        h.rgba[i + 3] = 0x3C00;
      }
    return h;
  }();
  return img;
}

inline EncodeSettings settings_for(Mode m, int threads) {
  EncodeSettings s;
  s.target = default_target(m);
  s.threads = threads;
  s.exposure.compensation_ev = 0.5;  // exercised, not trivial
  s.png_samples = false;             // the scan-out buffer only (PNG samples are a dump option)
  return s;
}

// The UI variant: a 1200x300 overlay, mostly 60 % opaque, at (100, 1700).
inline void add_ui_overlay(EncodeSettings& s) {
  static const auto overlay = [] {
    auto ov = std::make_shared<OverlayImage>();
    ov->width = 1200;
    ov->height = 300;
    ov->rgba.resize(static_cast<std::size_t>(ov->width) * ov->height * 4);
    for (std::size_t i = 0; i < ov->rgba.size(); i += 4) {
      ov->rgba[i] = 0.9f, ov->rgba[i + 1] = 0.9f, ov->rgba[i + 2] = 1.0f;
      ov->rgba[i + 3] = (i / 4) % 7 == 0 ? 1.0f : 0.6f;
    }
    return std::shared_ptr<const OverlayImage>(ov);
  }();
  s.ui.overlay = overlay;
  s.ui.x = 100, s.ui.y = 1700;
}

}  // namespace hdrd::bench

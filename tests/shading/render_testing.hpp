// Shared by the GPU tests: one renderer per test binary (a GL context costs ~100 ms on
// llvmpipe), skipping cleanly only when no GL context at all can be made.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "shading/renderer.hpp"

namespace hdrd::shading::testing {

struct SharedRenderer {
  std::unique_ptr<Renderer> renderer;
  std::string why_not;
  bool broken = false;  // a context exists but the renderer failed (e.g. a shader): fail, never skip
};

inline SharedRenderer& shared_renderer() {
  static SharedRenderer s = [] {
    SharedRenderer r;
    auto c = Renderer::create(Backend::automatic);
    if (c) {
      r.renderer = std::move(*c);
    } else {
      r.why_not = c.error().message;
      r.broken = c.error().code == "gl.shader";
    }
    return r;
  }();
  return s;
}

// The world-space ray through the centre of pixel (x, y) (rows top-down), as the
// renderer's perspective projection defines it.
inline Vec3 pixel_ray(const Camera& c, int width, int height, int x, int y) {
  const double aspect = double(width) / height, t = std::tan(c.yfov_rad / 2);
  const double ndc_x = (x + 0.5) / width * 2 - 1, ndc_y = 1 - (y + 0.5) / height * 2;
  const Mat4 inv_view = inverse(look_at(c.position, c.target, c.up));
  return normalize(inv_view.transform_dir({ndc_x * t * aspect, ndc_y * t, -1}));
}

inline double luma(const float* p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

}  // namespace hdrd::shading::testing

#define HDRD_REQUIRE_RENDERER(var)                                                        \
  auto& var##_shared = ::hdrd::shading::testing::shared_renderer();                       \
  if (var##_shared.broken) FAIL() << "renderer set-up failed: " << var##_shared.why_not;   \
  if (!var##_shared.renderer) GTEST_SKIP() << "no GL context: " << var##_shared.why_not;  \
  ::hdrd::shading::Renderer& var = *var##_shared.renderer;                              \
  (void)var

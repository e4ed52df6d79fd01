// The fast encode path's building blocks against the reference functions: the per-octave
// polynomials (FloatBitsPoly) and the fused kernel on every SIMD target this CPU runs.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <random>

#include "encode/float_poly.hpp"
#include "encode/pipeline.hpp"
#include "encode/pipeline_internal.hpp"
#include "encode/transfer.hpp"

using namespace hdrd;

namespace {

double pq(double nits) { return transfer::pq_inverse_eotf(nits); }

TEST(FloatBitsPoly, PqWithinAMillionthOfTheSignalEverywhere) {
  const FloatBitsPoly p(pq, -30, 14);
  EXPECT_LE(p.max_error(), detail::kSignalPolyTolerance);
  // Independent of the constructor's own sampling: random floats over the whole range,
  // the published anchors (REFERENCE.md: 100 cd/m2 -> 0.508078, 1000 -> 0.751827).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> e(-30, 14);
  for (int i = 0; i < 200000; ++i) {
    const float v = static_cast<float>(std::exp2(e(rng)));
    ASSERT_NEAR(p(v), pq(v), 1e-6) << v;
  }
  EXPECT_NEAR(p(100.0f), 0.508078, 2e-6);
  EXPECT_NEAR(p(1000.0f), 0.751827, 2e-6);
  EXPECT_NEAR(p(10000.0f), 1.0, 2e-6);
}

TEST(FloatBitsPoly, OctavesMeetAndTheEndsClampLikeTheTable) {
  const FloatBitsPoly p(pq, -30, 14);
  for (int e = -29; e < 14; ++e) {
    const float at = std::ldexp(1.0f, e);
    const float below = std::nextafter(at, 0.0f);
    EXPECT_NEAR(p(at), p(below), 3e-7) << "octave boundary 2^" << e;
    EXPECT_GE(p(at), p(below) - 3e-7f);
  }
  EXPECT_FLOAT_EQ(p(0.0f), p(p.lo()));
  EXPECT_FLOAT_EQ(p(-5.0f), p(p.lo()));
  EXPECT_FLOAT_EQ(p(NAN), p(p.lo()));
  EXPECT_FLOAT_EQ(p(1e30f), p(p.hi_prev()));
  EXPECT_NEAR(p(p.lo()), pq(p.lo()), 1e-9);
}

TEST(FloatBitsPoly, KinksDoNotFitAndAreReportedSo) {
  // sRGB clipped at the display peak inside an octave: the stage keeps the table.
  const FloatBitsPoly srgb([](double n) { return transfer::srgb_inverse_eotf(std::min(n / 100.0, 1.0)); }, -20, 14);
  EXPECT_GT(srgb.max_error(), 1e-3);
  EXPECT_TRUE(detail::build_signal_stage(default_target(Mode::sdr)).signal_poly.empty());
  EXPECT_FALSE(detail::build_signal_stage(default_target(Mode::hdr10)).signal_poly.empty());
  EXPECT_THROW(FloatBitsPoly(pq, 0, 65), std::invalid_argument);
}

TEST(FloatBitsPoly, RelativeErrorOfSmoothCurves) {
  const FloatBitsPoly p([](double x) { return x / (1 + x); }, -20, 20);
  EXPECT_LT(p.max_relative_error(), 1e-4);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> e(-20, 20);
  for (int i = 0; i < 10000; ++i) {
    const float v = static_cast<float>(std::exp2(e(rng)));
    const double want = static_cast<double>(v) / (1.0 + v);
    ASSERT_NEAR(p(v) / want, 1.0, p.max_relative_error() * 1.01) << v;
  }
}

std::array<int, 3> codes_at(const EncodedFrame& f, std::size_t i) {
  std::uint32_t w;
  std::memcpy(&w, f.data.data() + i * 4, 4);
  return {static_cast<int>(w & 1023), static_cast<int>((w >> 10) & 1023), static_cast<int>((w >> 20) & 1023)};
}

// Every kernel compiled into the binary that this CPU can run (scalar .. AVX-512: the
// table gathers on most, the polynomial permutes on AVX-512) encodes HDR10, with a UI,
// within one code of the staged path, with the same content light.
TEST(FusedKernel, EveryCompiledTargetMatchesTheStagedPath) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> stops(-24, 7);
  Image img(203, 17);  // odd width: the scalar tail too
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = std::exp2(stops(rng));
    img.rgba[i * 4 + 3] = 1;
  }
  img.rgba[0] = 0, img.rgba[1] = 0, img.rgba[2] = 0;  // true black
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 40;
  overlay->height = 5;
  for (int i = 0; i < 200; ++i) overlay->rgba.insert(overlay->rgba.end(), {1.0f, 0.3f, 0.0f, (i % 3) / 2.0f});
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.threads = 1;
  s.ui.overlay = overlay;
  s.ui.x = 30, s.ui.y = 6;
  SceneInput in;
  in.image = &img;
  auto staged = s;
  staged.keep_display_nits = true;  // forces the staged path
  const auto want = encode_frame(in, staged);
  ASSERT_TRUE(want.ok());
  const auto targets = hwy::SupportedAndGeneratedTargets();
  EXPECT_GE(targets.size(), 2u);
  for (const auto target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    const auto got = encode_frame(in, s);
    ASSERT_TRUE(got.ok());
    int off = 0;
    for (std::size_t i = 0; i < img.pixel_count(); ++i) {
      const auto a = codes_at(*got, i), b = codes_at(*want, i);
      for (int c = 0; c < 3; ++c) {
        ASSERT_LE(std::abs(a[c] - b[c]), 1) << hwy::TargetName(target) << " pixel " << i;
        off += a[c] != b[c];
      }
    }
    EXPECT_LT(off, static_cast<int>(img.pixel_count() * 3 / 200)) << hwy::TargetName(target);
    EXPECT_EQ(codes_at(*got, 0), (std::array<int, 3>{0, 0, 0})) << hwy::TargetName(target);
    EXPECT_NEAR(got->content_light.max_cll_nits, want->content_light.max_cll_nits, 1e-3) << hwy::TargetName(target);
    EXPECT_NEAR(got->content_light.max_fall_nits, want->content_light.max_fall_nits,
                want->content_light.max_fall_nits * 1e-3)
        << hwy::TargetName(target);
  }
  hwy::SetSupportedTargetsForTest(0);
}

}  // namespace

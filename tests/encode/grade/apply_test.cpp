// LUT application: the identity is the identity; the SIMD fast path equals the reference
// evaluation; and both equal OpenColorIO's FileTransform (INTERP_TETRAHEDRAL and
// INTERP_LINEAR) on random tables and random colours, inside and outside the domain.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <optional>
#include <random>

#include <hwy/targets.h>

#include "encode/grade/lut.hpp"
#include "encode/grade/ocio.hpp"
#include "tests/encode/grade/grade_testing.hpp"
#include "tests/testing/testing.hpp"

using namespace hdrd;
using namespace hdrd::lut;
using grade_testing::random_colours;

namespace {

constexpr Interpolation kBoth[] = {Interpolation::tetrahedral, Interpolation::trilinear};

std::vector<float> to_rgba(const std::vector<Rgb>& colours) {
  std::vector<float> px(colours.size() * 4);
  for (std::size_t i = 0; i < colours.size(); ++i) {
    std::copy(colours[i].begin(), colours[i].end(), px.begin() + 4 * i);
    px[4 * i + 3] = 0.25f + float(i % 7);  // alpha must come through untouched
  }
  return px;
}

float max_abs_diff(Rgb a, Rgb b) {
  return std::max({std::fabs(a[0] - b[0]), std::fabs(a[1] - b[1]), std::fabs(a[2] - b[2])});
}

TEST(Apply, IdentityIsIdentity) {
  std::mt19937 rng(1);
  const auto colours = random_colours(5000, 0.0f, 1.0f, rng);
  for (int size : {2, 17, 33, 65})
    for (auto interp : kBoth) {
      const Lut3D id = Lut3D::identity(size);
      auto px = to_rgba(colours);
      Applier3D(id, interp).apply(px.data(), colours.size(), 2);
      float worst = 0;
      for (std::size_t i = 0; i < colours.size(); ++i) {
        worst = std::max(worst, max_abs_diff({px[4 * i], px[4 * i + 1], px[4 * i + 2]}, colours[i]));
        worst = std::max(worst, max_abs_diff(eval(id, colours[i], interp), colours[i]));
        ASSERT_EQ(px[4 * i + 3], 0.25f + float(i % 7));
      }
      EXPECT_LE(worst, 1e-5f) << "size " << size << " " << to_string(interp);
    }
}

TEST(Apply, FastPathEqualsReference) {
  std::mt19937 rng(2);
  for (int size : {2, 5, 33})
    for (auto interp : kBoth) {
      Lut3D l = grade_testing::random_lut3d(size, rng);
      l.domain.min = {-0.25f, 0.0f, 0.1f};
      l.domain.max = {1.25f, 2.0f, 0.9f};
      // Includes values outside the domain (clamped to the edges) and odd counts that end
      // in a partial SIMD vector.
      auto colours = random_colours(1000 + size, -0.5f, 2.5f, rng);
      colours.push_back({std::nanf(""), 0.5f, 0.5f});
      colours.push_back({INFINITY, -INFINITY, 0.5f});
      for (int threads : {1, 3}) {
        auto px = to_rgba(colours);
        Applier3D(l, interp).apply(px.data(), colours.size(), threads);
        for (std::size_t i = 0; i < colours.size(); ++i) {
          const Rgb ref = eval(l, colours[i], interp);
          ASSERT_LE(max_abs_diff({px[4 * i], px[4 * i + 1], px[4 * i + 2]}, ref), 2e-6f)
              << "size " << size << " " << to_string(interp) << " pixel " << i;
        }
      }
    }
}

// IEEE binary16 <-> float, written out (not through the code under test).
float half_to_float(std::uint16_t h) {
  const int e = (h >> 10) & 0x1F, m = h & 0x3FF;
  const float v = e == 0 ? std::ldexp(float(m), -24) : e == 31 ? INFINITY : std::ldexp(float(m | 0x400), e - 25);
  return (h & 0x8000) ? -v : v;
}
// Round to nearest even (std::nearbyint in the default rounding mode); finite range only.
std::uint16_t float_to_half_rne(float f) {
  const std::uint16_t sign = std::signbit(f) ? 0x8000 : 0;
  const double a = std::fabs(double(f));
  if (a < std::ldexp(1.0, -14)) return sign | std::uint16_t(std::nearbyint(a * std::ldexp(1.0, 24)));
  int e = std::ilogb(a);
  double q = std::nearbyint(a * std::ldexp(1.0, 10 - e));
  if (q == 2048) q = 1024, ++e;
  return sign | std::uint16_t(((e + 15) << 10) | (int(q) - 1024));
}

TEST(Apply, HalfPathRoundsTheReference) {
  std::mt19937 rng(4);
  const Lut3D l = grade_testing::random_lut3d(17, rng);
  const auto colours = random_colours(777, 0.0f, 1.0f, rng);
  std::vector<std::uint16_t> in(colours.size() * 4), out(in.size());
  for (std::size_t i = 0; i < colours.size(); ++i) {
    for (int c = 0; c < 3; ++c) in[4 * i + c] = float_to_half_rne(colours[i][c]);
    in[4 * i + 3] = std::uint16_t(0x3C00 + i);  // alpha bits pass through
  }
  for (auto interp : kBoth) {
    Applier3D(l, interp).apply_half(in.data(), out.data(), colours.size(), 2);
    for (std::size_t i = 0; i < colours.size(); ++i) {
      const Rgb x = {half_to_float(in[4 * i]), half_to_float(in[4 * i + 1]), half_to_float(in[4 * i + 2])};
      const Rgb ref = eval(l, x, interp);
      for (int c = 0; c < 3; ++c) {
        const float got = half_to_float(out[4 * i + c]);
        // one half ULP of the value (plus float noise at rounding ties)
        ASSERT_LE(std::fabs(got - ref[c]), std::ldexp(1.0f, std::ilogb(std::max(std::fabs(ref[c]), 6.1e-5f)) - 11) + 1e-6f)
            << to_string(interp) << " pixel " << i << " ch " << c;
      }
      ASSERT_EQ(out[4 * i + 3], in[4 * i + 3]);
    }
  }
}

// The acceptance check: hdrd's application equals OpenColorIO's FileTransform on the
// same .cube file, for random tables and colours, within 1e-5.
TEST(Apply, MatchesOpenColorIOFileTransform) {
  hdrd::testing::TempDir dir;
  std::mt19937 rng(5);
  int compared = 0;
  // OCIO parses a 33^3 .cube in ~0.2 s (64^3 in ~1.4 s), so sizes stay small here.
  for (int size : {2, 9, 33})
    for (bool domain : {false, true})
      for (auto interp : kBoth) {
        CubeFile cube;
        cube.lut3d = grade_testing::random_lut3d(size, rng);
        if (domain) {
          cube.lut3d->domain.min = {-0.125f, 0.0f, 0.25f};
          cube.lut3d->domain.max = {1.5f, 4.0f, 1.0f};
        }
        const auto path = dir / fmt::format("r{}_{}_{}.cube", size, domain, int(interp));
        ASSERT_TRUE(write_cube(cube, path).ok());
        const grade_testing::OcioFile ocio_ref(path, interp == Interpolation::tetrahedral);
        std::optional<ocio::Processor> ours_ocio;  // the wrapper hdrd uses for other formats
        if (size == 9) ours_ocio = ocio::file_transform(path, interp).value();
        const auto colours = random_colours(2000, -0.25f, domain ? 4.25f : 1.25f, rng);
        auto px = to_rgba(colours);
        Applier3D(*cube.lut3d, interp).apply(px.data(), colours.size());
        for (std::size_t i = 0; i < colours.size(); ++i) {
          const Rgb want = ocio_ref.apply(colours[i]);
          ASSERT_LE(max_abs_diff({px[4 * i], px[4 * i + 1], px[4 * i + 2]}, want), 1e-5f)
              << path << " colour " << colours[i][0] << " " << colours[i][1] << " " << colours[i][2];
          ASSERT_LE(max_abs_diff(eval(cube, colours[i], interp), want), 1e-5f);
          if (ours_ocio) { ASSERT_LE(max_abs_diff(ours_ocio->apply(colours[i]), want), 1e-7f); }
          ++compared;
        }
      }
  EXPECT_EQ(compared, 3 * 2 * 2 * 2000);
}

TEST(Apply, OneDimensionalAndShaperFilesMatchOpenColorIO) {
  hdrd::testing::TempDir dir;
  std::mt19937 rng(6);
  // A 1D-only file with DOMAIN (Iridas/Adobe reader in OCIO) and a Resolve 1D shaper +
  // 3D file with LUT_*_INPUT_RANGE (OCIO's Resolve reader; no TITLE there).
  CubeFile only1d;
  only1d.lut1d = grade_testing::random_lut1d(1024, rng);
  only1d.lut1d->domain.min = {-0.5f, 0.0f, 0.0f};
  only1d.lut1d->domain.max = {1.0f, 2.0f, 1.0f};
  CubeFile both;
  both.lut1d = grade_testing::random_lut1d(64, rng);
  both.lut1d->domain.max = {2.0f, 2.0f, 2.0f};
  both.lut3d = grade_testing::random_lut3d(17, rng);
  int i = 0;
  for (const CubeFile* c : {&only1d, &both}) {
    const auto path = dir / fmt::format("f{}.cube", i++);
    ASSERT_TRUE(write_cube(*c, path).ok());
    for (auto interp : kBoth) {
      const grade_testing::OcioFile ocio_ref(path, interp == Interpolation::tetrahedral);
      for (const auto& col : random_colours(3000, -0.6f, 2.2f, rng))
        ASSERT_LE(max_abs_diff(eval(*c, col, interp), ocio_ref.apply(col)), 1e-5f) << path;
    }
  }
}

// Every kernel compiled into the binary that this CPU can run (SSSE3/SSE4/AVX2/AVX-512,
// the scalar fallback) gives the reference result: dynamic dispatch is exercised, not just
// the best target.
TEST(Apply, EveryCompiledTargetMatchesReference) {
  std::mt19937 rng(9);
  const Lut3D l = grade_testing::random_lut3d(9, rng);
  const auto colours = random_colours(203, -0.2f, 1.2f, rng);
  const auto targets = hwy::SupportedAndGeneratedTargets();
  EXPECT_GE(targets.size(), 2u);
  for (const auto target : targets) {
    hwy::SetSupportedTargetsForTest(target);
    EXPECT_EQ(simd_target_name(), hwy::TargetName(target));
    for (auto interp : kBoth) {
      auto px = to_rgba(colours);
      Applier3D(l, interp).apply(px.data(), colours.size());
      for (std::size_t i = 0; i < colours.size(); ++i)
        ASSERT_LE(max_abs_diff({px[4 * i], px[4 * i + 1], px[4 * i + 2]}, eval(l, colours[i], interp)), 2e-6f)
            << hwy::TargetName(target) << " " << to_string(interp);
    }
    // The PQ buffer shaper goes through the same dispatch.
    const ShaperTable pq(ShaperSpec{grade::Shaper::pq, 0, 10000});
    const std::vector<float> nits = {0, 0.005f, 1, 203, 1000, 10000, 20000, -1, NAN, 26, 100, 4000};
    std::vector<float> px;
    for (float v : nits) px.insert(px.end(), {v, v, v, 1.0f});
    pq.forward_rgba(px.data(), nits.size());
    for (std::size_t i = 0; i < nits.size(); ++i)
      EXPECT_NEAR(px[4 * i + 1], pq.forward(nits[i]), 1e-7) << hwy::TargetName(target) << " " << nits[i];
  }
  hwy::SetSupportedTargetsForTest(0);
}

TEST(Apply, SimdTargetIsReported) {
  const std::string t = simd_target_name();
  EXPECT_FALSE(t.empty());
  EXPECT_NE(t, "none");
}

}  // namespace

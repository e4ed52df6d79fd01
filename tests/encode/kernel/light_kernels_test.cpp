// The light-statistics kernels (encode/kernel/light_kernels.hpp) on every Highway target
// against their scalar definitions, written out here: counts and maxima must be equal, the
// half conversion bit-exact (NaN for NaN) over all 65536 halves.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "encode/image.hpp"
#include "encode/kernel/light_kernels.hpp"

using namespace hdrd;

namespace {

// IEEE 754 binary16 -> binary32, from the format's definition.
float half_definition(std::uint16_t h) {
  const int sign = h >> 15, exp = (h >> 10) & 31, mant = h & 1023;
  double v;
  if (exp == 0) v = std::ldexp(mant, -24);
  else if (exp == 31) v = mant ? NAN : INFINITY;
  else v = std::ldexp(1024 + mant, exp - 25);
  return static_cast<float>(sign ? -v : v);
}

void expect_same_float(float got, float want, const char* what, std::size_t i, std::uint64_t target) {
  if (std::isnan(want)) {
    EXPECT_TRUE(std::isnan(got)) << hwy::TargetName(target) << " " << what << " " << i;
  } else {
    EXPECT_EQ(std::bit_cast<std::uint32_t>(got), std::bit_cast<std::uint32_t>(want))
        << hwy::TargetName(target) << " " << what << " " << i << ": " << got << " vs " << want;
  }
}

}  // namespace

TEST(LightKernels, MaxCodeHistogramCountsEveryPixelsLargestCode) {
  std::mt19937 rng(7);
  // Widths that leave every tail length of a 16-lane target, rows with padding.
  for (const int width : {1, 15, 16, 17, 531, 1013}) {
    const int height = 5;
    const std::size_t stride = static_cast<std::size_t>(width) * 4 + 12;
    std::vector<std::uint8_t> data(stride * height, 0xAB);  // padding that must not count
    std::uniform_int_distribution<int> any(0, 1023), near(0, 6);
    std::array<std::uint64_t, 1024> want{};
    std::array<std::uint32_t, 3> want_max{5, 0, 0};  // accumulates into what it holds
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        // Runs of equal codes (the interleaved tables' case) and the extremes.
        std::uint32_t c[3];
        for (auto& v : c) v = static_cast<std::uint32_t>(x % 9 == 0 ? any(rng) : (x % 3 == 0 ? 1023 : 400 + near(rng)));
        const std::uint32_t w = c[0] | (c[1] << 10) | (c[2] << 20) | (static_cast<std::uint32_t>(x & 3) << 30);
        std::memcpy(data.data() + y * stride + static_cast<std::size_t>(x) * 4, &w, 4);
        ++want[std::max({c[0], c[1], c[2]})];
        for (int k = 0; k < 3; ++k) want_max[k] = std::max(want_max[k], c[k]);
      }
    hwy::SetSupportedTargetsForTest(0);
    for (const auto target : hwy::SupportedAndGeneratedTargets()) {
      hwy::SetSupportedTargetsForTest(target);
      std::array<std::uint64_t, 1024> got{};
      std::array<std::uint32_t, 3> got_max{5, 0, 0};
      kernels::max_code_histogram(data.data(), width, height, stride, got, got_max);
      EXPECT_EQ(got, want) << hwy::TargetName(target) << " width " << width;
      EXPECT_EQ(got_max, want_max) << hwy::TargetName(target) << " width " << width;
    }
  }
  hwy::SetSupportedTargetsForTest(0);
}

TEST(LightKernels, StridedHalvesAreExactlyTheHalfDefinition) {
  // Every half as R (and shifted as G, B), read at step 1.
  std::vector<std::uint16_t> all(65536 * 4);
  for (std::size_t i = 0; i < 65536; ++i) {
    all[i * 4] = static_cast<std::uint16_t>(i);
    all[i * 4 + 1] = static_cast<std::uint16_t>(i ^ 0x8000);
    all[i * 4 + 2] = static_cast<std::uint16_t>(i * 7);
    all[i * 4 + 3] = 0x3C00;
  }
  hwy::SetSupportedTargetsForTest(0);
  for (const auto target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    std::vector<float> r(65536), g(65536), b(65536);
    kernels::strided_half_rgb(all.data(), 1, 65536, r.data(), g.data(), b.data());
    for (std::size_t i = 0; i < 65536; ++i) {
      expect_same_float(r[i], half_definition(all[i * 4]), "R", i, target);
      expect_same_float(g[i], half_definition(all[i * 4 + 1]), "G", i, target);
      expect_same_float(b[i], half_definition(all[i * 4 + 2]), "B", i, target);
      expect_same_float(r[i], half_to_float(all[i * 4]), "R (half_to_float)", i, target);
      if (HasFailure()) return;
    }
    // Strides and counts that leave partial blocks and partial vectors.
    for (const std::size_t step : {3u, 7u, 31u})
      for (const std::size_t count : {1u, 13u, 511u, 513u, 1500u}) {
        if (count * step > 65536) continue;
        std::vector<float> sr(count, -1), sg(count, -1), sb(count, -1);
        kernels::strided_half_rgb(all.data(), step, count, sr.data(), sg.data(), sb.data());
        for (std::size_t k = 0; k < count; ++k) {
          expect_same_float(sr[k], half_definition(all[k * step * 4]), "strided R", k, target);
          expect_same_float(sg[k], half_definition(all[k * step * 4 + 1]), "strided G", k, target);
          expect_same_float(sb[k], half_definition(all[k * step * 4 + 2]), "strided B", k, target);
        }
      }
  }
  hwy::SetSupportedTargetsForTest(0);
}

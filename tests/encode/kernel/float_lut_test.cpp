// The fast path's tables (float_lut.hpp). FloatBitsQuantizer must give, for every float,
// exactly the code the double-precision signal function rounds to: checked at the
// published PQ codes, on a log-uniform sweep, at every code boundary and the floats on
// either side of it, and at the ends of the range (0, negatives, denormals, the largest
// float).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>

#include "encode/kernel/float_lut.hpp"
#include "encode/tone/tonemap_curves.hpp"
#include "encode/colour/transfer.hpp"

using namespace hdrd;

namespace {

using CodeFn = std::function<int(double)>;

CodeFn full_range(std::function<double(double)> signal, int bits) {
  const double scale = std::ldexp(1.0, bits) - 1;
  return [=](double nits) {
    return static_cast<int>(std::floor(std::clamp(signal(nits), 0.0, 1.0) * scale + 0.5));
  };
}

CodeFn narrow_range(std::function<double(double)> signal, int bits) {
  const double k = std::ldexp(1.0, bits - 8);
  return [=](double nits) {
    return static_cast<int>(std::floor(std::clamp(signal(nits), 0.0, 1.0) * 219 * k + 16 * k + 0.5));
  };
}

double pq(double nits) { return transfer::pq_inverse_eotf(nits); }

// Every float the kernel can meet, compared with the function itself.
void expect_exact(const FloatBitsQuantizer& q, const CodeFn& code, const char* what) {
  ASSERT_FALSE(q.empty()) << what;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> log2_nits(-40, 20);
  long checked = 0;
  for (int i = 0; i < 200000; ++i) {
    const float v = static_cast<float>(std::exp2(log2_nits(rng)));
    ASSERT_EQ(q.code(v), code(v)) << what << " at " << v;
    ++checked;
  }
  // Each code boundary and its neighbours, found by walking the codes upwards.
  for (float v = 1e-12f; v < 2e4f;) {
    const int c = code(v);
    std::uint32_t a = std::bit_cast<std::uint32_t>(v), b = std::bit_cast<std::uint32_t>(3e4f);
    if (code(std::bit_cast<float>(b)) == c) break;
    while (b - a > 1) {
      const std::uint32_t m = a + (b - a) / 2;
      (code(std::bit_cast<float>(m)) > c ? b : a) = m;
    }
    for (std::uint32_t bits : {a - 1, a, b, b + 1}) {
      const float x = std::bit_cast<float>(bits);
      ASSERT_EQ(q.code(x), code(x)) << what << " next to the start of code " << c + 1 << ", at " << x;
    }
    checked += 4;
    v = std::bit_cast<float>(b);
  }
  for (float x : {0.0f, -0.0f, -1.0f, -std::numeric_limits<float>::max(), std::numeric_limits<float>::denorm_min(),
                  std::numeric_limits<float>::min(), 1e30f, std::numeric_limits<float>::max()})
    EXPECT_EQ(q.code(x), code(std::max(0.0f, x))) << what << " at " << x;
  EXPECT_GT(checked, 200000) << what;
}

TEST(FloatBitsQuantizer, PublishedPqCodes) {
  // REFERENCE.md §2 (BT.2408): nits -> 10-bit full and narrow codes.
  struct Row {
    float nits;
    int full10, narrow10;
  };
  const FloatBitsQuantizer full(full_range(pq, 10), -30, 14), narrow(narrow_range(pq, 10), -30, 14);
  for (const Row r : {Row{0.005f, 15, 77}, Row{0.1f, 64, 119}, Row{1, 153, 195}, Row{26, 389, 397}, Row{80, 497, 490},
                      Row{100, 520, 509}, Row{203, 594, 573}, Row{400, 668, 636}, Row{1000, 769, 723},
                      Row{4000, 923, 855}, Row{10000, 1023, 940}}) {
    EXPECT_EQ(full.code(r.nits), r.full10) << r.nits;
    EXPECT_EQ(narrow.code(r.nits), r.narrow10) << r.nits;
  }
  EXPECT_EQ(full.code(0), 0);
  EXPECT_EQ(narrow.code(0), 64);
  EXPECT_EQ(full.code(1e6f), 1023);
}

TEST(FloatBitsQuantizer, ExactForPqFullAndNarrow) {
  expect_exact(FloatBitsQuantizer(full_range(pq, 10), -30, 14), full_range(pq, 10), "PQ 10-bit full");
  expect_exact(FloatBitsQuantizer(narrow_range(pq, 10), -30, 14), narrow_range(pq, 10), "PQ 10-bit narrow");
}

TEST(FloatBitsQuantizer, ExactForSdrCurves) {
  const double peak = 203;
  auto srgb = [=](double n) { return transfer::srgb_inverse_eotf(std::min(n / peak, 1.0)); };
  auto g22 = [=](double n) { return transfer::gamma22_inverse_eotf(std::min(n / peak, 1.0)); };
  const auto bt1886 = transfer::Bt1886::from_levels(peak, 0.1);
  auto b1886 = [=](double n) { return bt1886.inverse_eotf(n); };
  expect_exact(FloatBitsQuantizer(full_range(srgb, 8), -20, 14), full_range(srgb, 8), "sRGB 8-bit");
  expect_exact(FloatBitsQuantizer(full_range(srgb, 10), -20, 14), full_range(srgb, 10), "sRGB 10-bit");
  expect_exact(FloatBitsQuantizer(full_range(g22, 10), -20, 14), full_range(g22, 10), "gamma 2.2 10-bit");
  expect_exact(FloatBitsQuantizer(narrow_range(b1886, 8), -20, 14), narrow_range(b1886, 8), "BT.1886 8-bit narrow");
}

TEST(FloatBitsQuantizer, GridFollowsTheCodeDensity) {
  // 10-bit PQ codes are at least 1/78 octave apart: 128 buckets per octave hold one each;
  // 10-bit sRGB codes near white are 1/311 octave apart and need 512.
  EXPECT_EQ(FloatBitsQuantizer(full_range(pq, 10), -30, 14).shift(), 23 - 7);
  auto srgb = [](double n) { return transfer::srgb_inverse_eotf(std::min(n / 100, 1.0)); };
  EXPECT_EQ(FloatBitsQuantizer(full_range(srgb, 10), -20, 14).shift(), 23 - 9);
}

TEST(FloatBitsQuantizer, RefusesWhatItCannotTabulate) {
  // Not constant below the range (the kernel clamps there).
  EXPECT_TRUE(FloatBitsQuantizer([](double x) { return x > 0 ? 1 : 0; }, -20, 14).empty());
  // Not constant above it.
  EXPECT_TRUE(FloatBitsQuantizer([](double x) { return x > 1e5 ? 1 : 0; }, -20, 14).empty());
  // A code no float reaches (a jump of two).
  EXPECT_TRUE(FloatBitsQuantizer([](double x) { return x >= 1 ? 2 : 0; }, -20, 14).empty());
  // Boundaries denser than 2048 per octave.
  EXPECT_TRUE(FloatBitsQuantizer([](double x) { return static_cast<int>(std::clamp(x, 1.0, 2.0) * 4000); }, -20, 14)
                  .empty());
  // Codes that do not fit the entry.
  EXPECT_TRUE(FloatBitsQuantizer([](double x) { return x >= 1 ? 1 << 16 : (1 << 16) - 1; }, -20, 14).empty());
}

// flat_below(): where a table is flat from its bottom, the SIMD kernel skips the lookup
// and uses table().front(). That must be the lookup's exact result for every float below
// it, and the table must not be flat any further.
TEST(FloatBitsLut, FlatBelowIsExactlyWhereTheTableIsFlat) {
  // pq-shoulder's ratio (nits out per relative unit in): paper white up to the knee, then
  // rolling off into the peak.
  const double pw = 203;
  const tonemap::detail::PqShoulder shoulder(1000, pw, 0.5);
  const FloatBitsLut ratio([&](double m) { return shoulder.map_nits(m * pw) / m; }, -20, 20);
  const float knee = static_cast<float>(transfer::pq_eotf(shoulder.e_knee) / pw);
  const float flat = ratio.flat_below();
  EXPECT_EQ(ratio.table().front(), static_cast<float>(pw));
  // The table's grid (128 points per octave) ends the flat part at the last grid point
  // at or below the knee.
  EXPECT_LE(flat, knee);
  EXPECT_GT(flat, knee * 0.99f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> log2_x(-40, std::log2(flat));
  for (int i = 0; i < 100000; ++i) {
    const float x = static_cast<float>(std::exp2(log2_x(rng)));
    if (x < flat) {
      ASSERT_EQ(ratio(x), ratio.table().front()) << x;
    }
  }
  for (float x : {0.0f, -0.0f, -1.0f, std::numeric_limits<float>::denorm_min(), std::nextafter(flat, 0.0f)})
    EXPECT_EQ(ratio(x), ratio.table().front()) << x;
  // Just past it the curve bends: some value in the next bucket differs.
  const float next_bucket_end = std::bit_cast<float>(std::bit_cast<std::uint32_t>(flat) + (1u << FloatBitsLut::kShift));
  EXPECT_NE(ratio(std::nextafter(next_bucket_end, 0.0f)), ratio.table().front());

  // A curve that changes from the first bucket on has no flat part (a ratio such as
  // 1 / (1 + m) does: in float it is 1 - 2^-20 over the first few buckets); a constant one
  // is flat throughout.
  EXPECT_EQ(FloatBitsLut([](double m) { return std::log2(m); }, -20, 20).flat_below(), 0.0f);
  const FloatBitsLut constant([](double) { return 5.0; }, -20, 20);
  EXPECT_EQ(constant.flat_below(), constant.hi());
}

}  // namespace

namespace {

// A kink inside a bucket (a clip at 1000, a slope change) is a node of its own: the lookup
// follows each side exactly, where plain interpolation across the bucket misses by up to a
// quarter of the slope jump times the bucket width.
TEST(FloatBitsLutKinks, KinksInsideABucketAreNodes) {
  // 1003 (1000 itself is a node: 1.953125 x 2^9 has no bits below the bucket index).
  auto clip = [](double x) { return std::min(x, 1003.0); };
  const double kinks[] = {1003.0};
  const FloatBitsLut plain(clip, -20, 14), patched(clip, -20, 14, kinks);
  ASSERT_EQ(patched.patches().size(), 1u);
  double worst_plain = 0, worst_patched = 0;
  for (int j = -3000; j <= 3000; ++j) {
    const float v = static_cast<float>(1003.0 * (1 + 2e-6 * j));
    worst_plain = std::max(worst_plain, std::abs(plain(v) - clip(v)));
    worst_patched = std::max(worst_patched, std::abs(patched(v) - clip(v)));
  }
  EXPECT_GT(worst_plain, 0.5);        // the old corner error: ~1.4 below the clip
  EXPECT_LT(worst_patched, 1000 * 1e-6);
  // Two kinks in one bucket (1 / 128 octave is 5.4 wide at 1000), and one on a node.
  auto two = [](double x) { return x < 1000.5 ? x : (x < 1002.0 ? 1000.5 + 0.5 * (x - 1000.5) : 1001.25); };
  const double two_kinks[] = {1000.5, 1002.0, 1024.0};
  const FloatBitsLut both(two, -20, 14, two_kinks);
  EXPECT_EQ(both.patches().size(), 2u);  // 1024 is a node already
  for (int j = -4000; j <= 4000; ++j) {
    const float v = static_cast<float>(1001.0 * (1 + 2e-6 * j));
    ASSERT_NEAR(both(v), two(v), 1001 * 1e-6) << v;
  }
  // Far from the kink the table is what it was.
  for (float v : {0.5f, 10.0f, 200.0f, 4000.0f}) EXPECT_EQ(patched(v), plain(v)) << v;
}

TEST(FloatBitsLutKinks, FlatRunEndsAtAPatchedBucket) {
  // Flat (1) at every node, with a bump inside the bucket [3.09375, 3.109375): the table's
  // values alone would call everything below 2^10 flat.
  auto bump = [](double x) { return 1.0 + std::max(0.0, 0.004 - std::abs(x - 3.1)); };
  const double kinks[] = {3.096, 3.1, 3.104};
  const FloatBitsLut l(bump, -10, 10, kinks);
  EXPECT_EQ(l.patches().size(), 3u);
  ASSERT_GT(l.flat_below(), 0.0f);
  EXPECT_LE(l.flat_below(), 3.09375f);
  EXPECT_NEAR(l(3.1f), 1.004f, 1e-6);
  EXPECT_NEAR(l(3.098f), 1.002f, 1e-6);
}

}  // namespace

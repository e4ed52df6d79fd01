// Sequence metadata (encode/video/sequence_metadata.hpp): per-frame light decoded from the
// codes and checked against ST 2084 evaluated here; scenes; MaxCLL/MaxFALL of a sequence;
// HDR10+ within ST 2094-40's ranges in x265's JSON layout; Dolby Vision level 1 in
// dovi_tool's; the profile B Bezier curve against BT.2390.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "encode/video/sequence_metadata.hpp"
#include "tests/encode/video/video_testing.hpp"

using namespace hdrd;
using namespace hdrd::video;
using namespace hdrd::video::testing;

namespace {

// SMPTE ST 2084, written out here (REFERENCE.md §2 constants).
double pq_eotf(double e) {
  const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
               c3 = 2392.0 / 4096 * 32;
  const double p = std::pow(std::max(e, 0.0), 1 / m2);
  return 10000 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1 / m1);
}
double pq_inverse(double nits) {
  const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
               c3 = 2392.0 / 4096 * 32;
  const double y = std::pow(nits / 10000, m1);
  return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
}

// An HDR10 frame: a dim gradient, a few saturated colours and a highlight of `peak_code`.
EncodedFrame hdr10_frame(int w, int h, int base, int peak_code, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> jitter(-40, 40);
  return frame_of_codes(Mode::hdr10, Range::full, 10, w, h, [&](int x, int y) {
    if (x < 3 && y < 3) return std::array<int, 3>{peak_code, peak_code - 30, peak_code - 60};
    const int v = std::clamp(base + x * 3 + jitter(rng), 0, 1023);
    if (y % 7 == 0) return std::array<int, 3>{v, v / 3, v / 5};  // reds
    return std::array<int, 3>{v, v, std::clamp(v + 20, 0, 1023)};
  });
}

// maxRGB of every pixel, decoded here.
std::vector<double> max_rgb_nits(const EncodedFrame& f) {
  std::vector<double> v;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const Codes c = codes_at(f, x, y);
      v.push_back(pq_eotf(std::max({c.r, c.g, c.b}) / 1023.0));
    }
  return v;
}

TEST(FrameLight, MatchesSt2084DecodedHere) {
  const EncodedFrame f = hdr10_frame(64, 32, 300, 900, 1);
  const FrameLight l = measure_frame_light(f);
  auto v = max_rgb_nits(f);
  double sum = 0;
  for (double x : v) sum += x;
  EXPECT_NEAR(l.max_nits, *std::max_element(v.begin(), v.end()), 1e-3 * l.max_nits);
  EXPECT_NEAR(l.min_nits, *std::min_element(v.begin(), v.end()), 1e-3);
  EXPECT_NEAR(l.mean_nits, sum / v.size(), 1e-4 * l.mean_nits);
  EXPECT_NEAR(l.max_channel_nits[0], pq_eotf(900 / 1023.0), 0.5);
  EXPECT_NEAR(l.max_channel_nits[2], pq_eotf((900 - 60) / 1023.0), 0.5);  // the highlight's blue is its largest B
  std::uint64_t n = 0;
  for (auto c : l.pq_counts) n += c;
  EXPECT_EQ(n, 64u * 32u);
  // measure_content_light is the same measurement.
  const ContentLightLevel cl = measure_content_light(f);
  EXPECT_EQ(cl.max_cll_nits, l.max_nits);
  EXPECT_EQ(cl.max_fall_nits, l.mean_nits);
}

TEST(LightSummary, PercentilesAndPqStatisticsWithinTwelveBits) {
  const EncodedFrame f = hdr10_frame(80, 40, 200, 1000, 2);
  const FrameLight l = measure_frame_light(f);
  const FrameLight* one = &l;
  const LightSummary s = summarise(std::span<const FrameLight* const>(&one, 1));
  auto v = max_rgb_nits(f);
  std::sort(v.begin(), v.end());
  const double half_level = 0.5 / 4095 + 1e-7;
  for (std::size_t i = 0; i < kHdr10PlusPercentages.size(); ++i) {
    const auto rank = static_cast<std::size_t>(std::ceil(kHdr10PlusPercentages[i] / 100.0 * v.size()));
    EXPECT_NEAR(pq_inverse(s.percentile_nits[i]), pq_inverse(v[rank - 1]), half_level) << kHdr10PlusPercentages[i];
  }
  double pq_sum = 0;
  for (double x : v) pq_sum += pq_inverse(x);
  EXPECT_NEAR(s.mean_pq, pq_sum / v.size(), half_level);
  EXPECT_NEAR(s.max_pq, pq_inverse(v.back()), half_level);
  EXPECT_NEAR(s.min_pq, pq_inverse(v.front()), half_level);
}

std::vector<EncodedFrame> two_scenes() {
  std::vector<EncodedFrame> f;
  for (int i = 0; i < 4; ++i) f.push_back(hdr10_frame(32, 16, 250 + 5 * i, 780 + 10 * i, 10 + i));  // ~700 cd/m2 peaks
  for (int i = 0; i < 3; ++i) f.push_back(hdr10_frame(32, 16, 450 + 5 * i, 920 - 10 * i, 20 + i));  // brighter scene
  return f;
}

TEST(SequenceMetadata, ScenesContentLightAndPerSceneValues) {
  const auto frames = two_scenes();
  SequenceMetadata m(frames[0].target, frames[0].mastering);
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_TRUE(m.add(frames[i], i == 4).ok());
  m.finish();
  ASSERT_EQ(m.frame_count(), 7);
  ASSERT_EQ(m.scenes().size(), 2u);
  EXPECT_EQ(m.scenes()[0].first_frame, 0);
  EXPECT_EQ(m.scenes()[0].last_frame, 3);
  EXPECT_EQ(m.scenes()[1].first_frame, 4);
  EXPECT_EQ(m.scene_of(5), 1);
  // CTA-861.3: the largest pixel of any frame, the largest frame average.
  double max_cll = 0, max_fall = 0;
  for (const auto& f : frames) {
    const auto v = max_rgb_nits(f);
    max_cll = std::max(max_cll, *std::max_element(v.begin(), v.end()));
    double s = 0;
    for (double x : v) s += x;
    max_fall = std::max(max_fall, s / v.size());
  }
  EXPECT_NEAR(m.content_light().max_cll_nits, max_cll, 1e-3 * max_cll);
  EXPECT_NEAR(m.content_light().max_fall_nits, max_fall, 1e-3 * max_fall);
  // Frames of a scene share its values; the scene's maxscl is its frames' largest.
  EXPECT_EQ(m.hdr10plus(0).maxscl, m.hdr10plus(3).maxscl);
  EXPECT_NE(m.hdr10plus(3).maxscl, m.hdr10plus(4).maxscl);
  double scene1_max_r = 0;
  for (int i = 4; i < 7; ++i) scene1_max_r = std::max(scene1_max_r, measure_frame_light(frames[static_cast<std::size_t>(i)]).max_channel_nits[0]);
  EXPECT_EQ(m.hdr10plus(5).maxscl[0], static_cast<std::uint32_t>(std::lround(scene1_max_r * 10)));
  for (int i = 0; i < 7; ++i) {
    EXPECT_TRUE(validate(m.hdr10plus(i)).ok()) << i;
    const DoviL1 l = m.dovi_l1(i);
    EXPECT_LE(l.min_pq, l.avg_pq);
    EXPECT_LE(l.avg_pq, l.max_pq);
    EXPECT_LE(l.max_pq, 4095);
  }
  EXPECT_FALSE(m.add(frames[0], false).ok());  // finished
}

TEST(SequenceMetadata, FrameGranularityGivesEachFrameItsOwn) {
  const auto frames = two_scenes();
  SequenceMetadata m(frames[0].target, frames[0].mastering, {MetadataGranularity::frame, std::nullopt});
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_TRUE(m.add(frames[i], i == 4).ok());
  m.finish();
  EXPECT_NE(m.hdr10plus(0).maxscl, m.hdr10plus(1).maxscl);
  const auto own = measure_frame_light(frames[1]);
  EXPECT_EQ(m.hdr10plus(1).average_maxrgb, static_cast<std::uint32_t>(std::lround(own.mean_nits * 10)));
  const auto dovi = m.dovi_json();
  ASSERT_EQ(dovi["shots"].size(), 2u);
  EXPECT_EQ(dovi["shots"][0]["frame_edits"].size(), 4u);
  EXPECT_EQ(dovi["shots"][1]["frame_edits"][2]["edit_offset"], 2);
}

TEST(SequenceMetadata, Hdr10PlusJsonIsWhatX265Reads) {
  const auto frames = two_scenes();
  SequenceMetadata m(frames[0].target, frames[0].mastering);
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_TRUE(m.add(frames[i], i == 4).ok());
  m.finish();
  const auto j = m.hdr10plus_json();
  EXPECT_EQ(j["JSONInfo"]["HDR10plusProfile"], "A");
  EXPECT_EQ(j["JSONInfo"]["Version"], "1.0");
  ASSERT_EQ(j["SceneInfo"].size(), 7u);  // one entry per frame, in order
  EXPECT_EQ(j["SceneInfoSummary"]["SceneFirstFrameIndex"], (nlohmann::json{0, 4}));
  EXPECT_EQ(j["SceneInfoSummary"]["SceneFrameNumbers"], (nlohmann::json{4, 3}));
  for (int i = 0; i < 7; ++i) {
    const auto& e = j["SceneInfo"][static_cast<std::size_t>(i)];
    EXPECT_EQ(e["SequenceFrameIndex"], i);
    EXPECT_EQ(e["SceneId"], i < 4 ? 0 : 1);
    EXPECT_EQ(e["SceneFrameIndex"], i < 4 ? i : i - 4);
    // ST 2094-40 ranges, on what the file says.
    for (const auto& v : e["LuminanceParameters"]["MaxScl"]) EXPECT_LE(v.get<int>(), 100000);
    EXPECT_LE(e["LuminanceParameters"]["AverageRGB"].get<int>(), 100000);
    const auto& d = e["LuminanceParameters"]["LuminanceDistributions"];
    ASSERT_EQ(d["DistributionIndex"].size(), d["DistributionValues"].size());
    for (std::size_t k = 1; k < d["DistributionValues"].size(); ++k) {
      EXPECT_LT(d["DistributionIndex"][k - 1].get<int>(), d["DistributionIndex"][k].get<int>());
      EXPECT_LE(d["DistributionValues"][k - 1].get<int>(), d["DistributionValues"][k].get<int>());
    }
  }
  const auto dovi = m.dovi_json();
  EXPECT_EQ(dovi["profile"], "8.1");
  EXPECT_EQ(dovi["level6"]["max_display_mastering_luminance"], 1000);
  EXPECT_EQ(dovi["level6"]["min_display_mastering_luminance"], 50);  // 0.005 cd/m2 in 0.0001
  // Rounded up, never above the mastering maximum (the synthetic frames go above it).
  EXPECT_EQ(dovi["level6"]["max_content_light_level"],
            static_cast<int>(std::min(std::ceil(m.content_light().max_cll_nits - 1e-6), 1000.0)));
  EXPECT_EQ(dovi["shots"][1]["start"], 4);
  EXPECT_EQ(dovi["shots"][1]["duration"], 3);
  EXPECT_TRUE(dovi["shots"][0]["metadata_blocks"][0].contains("Level1"));
}

TEST(SequenceMetadata, DynamicMetadataIsForPq) {
  DisplayTarget hlg = default_target(Mode::hlg);
  SequenceMetadata m(hlg, hlg.mastering());
  EXPECT_FALSE(m.has_dynamic_metadata());
  const EncodedFrame f = hdr10_frame(8, 8, 100, 500, 3);
  EXPECT_EQ(m.add(f, true).error().code, "video.mode");
  // HLG: the sequence's content light is the frames' own (measured by the encoder).
  EncodedFrame a = frame_of_codes(Mode::hlg, Range::full, 10, 8, 8, [](int x, int) { return std::array<int, 3>{700 + x, 600, 500}; });
  EncodedFrame b = a;
  b.content_light = {250.0, 90.0};
  ASSERT_TRUE(m.add(a, true).ok());
  ASSERT_TRUE(m.add(b, false).ok());
  m.finish();
  EXPECT_EQ(m.content_light().max_cll_nits, std::max(a.content_light.max_cll_nits, 250.0));
  EXPECT_EQ(m.content_light().max_fall_nits, std::max(a.content_light.max_fall_nits, 90.0));
}

TEST(Bezier, FollowsBt2390AndStaysInRange) {
  for (double src : {1000.0, 4000.0, 10000.0})
    for (double tgt : {400.0, 600.0}) {
      auto b = fit_bezier(src, tgt);
      ASSERT_TRUE(b.has_value());
      ASSERT_EQ(b->anchors.size(), 9u);
      Hdr10PlusFrame m;
      m.distribution.push_back({50, 10});
      m.targeted_system_display_maximum_luminance = static_cast<std::uint32_t>(tgt);
      m.bezier = b;
      EXPECT_TRUE(validate(m).ok());
      EXPECT_TRUE(std::is_sorted(b->anchors.begin(), b->anchors.end())) << src << " -> " << tgt;
      // ST 2094-40's basis curve from the fitted values against BT.2390 (PQ domain, ITU-R BT.2390-10 §5.4).
      const double kx = b->knee_point_x / 4095.0, ky = b->knee_point_y / 4095.0;
      const double e_src = pq_inverse(src), lo = pq_inverse(tgt) / e_src, ks = 1.5 * lo - 0.5;
      double worst = 0;
      for (int step = 0; step <= 60; ++step) {
        const double x = std::pow(10.0, -3.0 + step / 20.0);  // 0.001 .. 1, dense in the darks
        double y;
        if (x <= kx) {
          y = ky / kx * x;
        } else {
          const double t = (x - kx) / (1 - kx);
          double bz = std::pow(t, 10);
          for (int k = 1; k <= 9; ++k) {
            double c = 1;
            for (int i = 1; i <= k; ++i) c = c * (10 - k + i) / i;
            bz += c * std::pow(t, k) * std::pow(1 - t, 10 - k) * b->anchors[static_cast<std::size_t>(k - 1)] / 1023.0;
          }
          y = ky + (1 - ky) * bz;
        }
        EXPECT_NEAR(y, bezier_curve(*b, x), 1e-9);
        const double e = pq_inverse(x * src) / e_src;
        double eo = e;
        if (e > ks) {  // Hermite spline above the knee
          const double t = (e - ks) / (1 - ks);
          eo = (2 * t * t * t - 3 * t * t + 1) * ks + (t * t * t - 2 * t * t + t) * (1 - ks) + (-2 * t * t * t + 3 * t * t) * lo;
        }
        const double want = pq_eotf(eo * e_src) / tgt;
        // In PQ: the curve's nine anchors cannot start steeper than slope 10, so strong
        // compression (10000 -> 400) bends early. Worst errors measured: docs/video.md.
        const double bound = src / tgt <= 2.5 ? 0.005 : src / tgt <= 10 ? 0.015 : 0.05;
        EXPECT_NEAR(pq_inverse(y * tgt), pq_inverse(want * tgt), bound) << src << " -> " << tgt << " at x = " << x;
        worst = std::max(worst, std::abs(pq_inverse(y * tgt) - pq_inverse(want * tgt)));
      }
      ::testing::Test::RecordProperty(fmt::format("bezier_{}_to_{}_worst_pq", src, tgt), fmt::format("{:.4f}", worst));
      std::printf("bezier %g -> %g: worst PQ error %.4f\n", src, tgt, worst);
    }
  EXPECT_FALSE(fit_bezier(300, 400).has_value());  // fits the display: no curve
}

TEST(SequenceMetadata, ProfileBCarriesTheScenesCurve) {
  const auto frames = two_scenes();
  SequenceMetadata m(frames[0].target, frames[0].mastering, {MetadataGranularity::scene, 400.0});
  for (std::size_t i = 0; i < frames.size(); ++i) ASSERT_TRUE(m.add(frames[i], i == 4).ok());
  m.finish();
  EXPECT_EQ(m.hdr10plus_json()["JSONInfo"]["HDR10plusProfile"], "B");
  const Hdr10PlusFrame f = m.hdr10plus(5);
  EXPECT_EQ(f.targeted_system_display_maximum_luminance, 400u);
  ASSERT_TRUE(f.bezier.has_value());
  EXPECT_TRUE(validate(f).ok());
  EXPECT_FALSE(validate(SequenceMetadataSettings{MetadataGranularity::scene, 50.0}).ok());
}

}  // namespace

// No code decodes above the display peak (issue 29 item 2): at every integer peak from 100
// to 10 000 cd/m2, in every HDR mode with codes (hdr10 full and narrow, HLG), the clip code
// decodes (ST 2084 / BT.2100 computed here, tests/testing/standards.hpp) to at most the peak
// and is the largest such code, the CPU encoders write nothing above it, and the MaxCLL
// every container carries stays at or below the mastering maximum. Rounding the peak to the
// nearest code put about half of these peaks one code above (150 -> code 562 = 150.09
// cd/m2, carried MaxCLL 151 against a mastering maximum of 150). scRGB has no codes (half
// floats); its carried MaxCLL is bounded by the same carried_light_level rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "encode/kernel/pipeline_internal.hpp"
#include "encode/pipeline.hpp"
#include "tests/testing/standards.hpp"

using namespace hdrd;
namespace standard = hdrd::testing::standard;

namespace {

// Light at 0.999, 1 and 4 x the peak (the clip curve passes it on, then clips at the peak).
Image ramp_around(double peak) {
  Image img(3, 1);
  const double nits[3] = {0.999 * peak, peak, 4 * peak};
  for (int i = 0; i < 3; ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[static_cast<std::size_t>(i) * 4 + c] = static_cast<float>(nits[i]);
    img.rgba[static_cast<std::size_t>(i) * 4 + 3] = 1;
  }
  return img;
}

int brightest_code(const EncodedFrame& f) {
  int top = 0;
  for (int x = 0; x < f.width; ++x) {
    std::uint32_t w;
    std::memcpy(&w, f.data.data() + static_cast<std::size_t>(x) * 4, 4);
    top = std::max({top, int(w & 1023), int((w >> 10) & 1023), int((w >> 20) & 1023)});
  }
  return top;
}

// BT.2100's published 8-digit HLG constants put OETF^-1(1) at 1 + 2.1e-8, not 1: the
// oracle's own rounding, allowed for HLG; PQ is compared exactly.
double slack(Mode m) { return m == Mode::hlg ? 1e-7 : 1e-12; }

// The light a 10-bit code decodes to, from the standards' equations.
double decoded_nits(const DisplayTarget& t, int code) {
  const double e = t.range == Range::narrow ? std::clamp((code / 4.0 - 16) / 219, 0.0, 1.0) : code / 1023.0;
  if (t.mode == Mode::hdr10) return standard::pq_eotf(e);
  return standard::hlg_eotf({e, e, e}, t.peak_nits, t.black_nits)[0];  // grey: every channel alike
}

struct Mode10 {
  Mode mode;
  Range range;
};
const Mode10 kModes[] = {{Mode::hdr10, Range::full}, {Mode::hdr10, Range::narrow}, {Mode::hlg, Range::full}};

DisplayTarget target(const Mode10& m, double peak) {
  DisplayTarget t = default_target(m.mode);
  t.range = m.range;
  t.peak_nits = peak;
  t.paper_white_nits = std::min(203.0, peak);
  return t;
}

// Every integer peak, every HDR mode: the clip code every path takes (the staged and SIMD
// CPU encoders clamp to SignalStage::peak_code, the GPU program receives it as its max
// code: GpuProgram.ClipCodeIsThePeakCode) is the largest code whose ST 2084 / HLG value
// is at most the peak, the 16-bit PNG limit likewise, and MaxCLL carried from the light
// of that code stays within the mastering maximum. 30 000 targets in about a second; the
// encoders end to end at sampled peaks below.
TEST(PeakCode, ClipCodeAtEveryIntegerPeakInEveryHdrMode) {
  for (const auto& m : kModes) {
    int failures = 0;
    for (int peak = 100; peak <= 10000 && failures < 5; ++peak) {
      const DisplayTarget t = target(m, peak);
      const detail::PeakCodes p = detail::peak_codes(t);
      const int top = m.range == Range::narrow ? 940 : 1023;
      const double light = decoded_nits(t, p.code);
      const bool largest = p.code >= top || decoded_nits(t, p.code + 1) > peak;
      const bool sample_ok = m.range == Range::narrow || m.mode != Mode::hdr10 ||
                             (standard::pq_eotf(p.signal16 / 65535.0) <= peak * (1 + 1e-12) &&
                              (p.signal16 == 65535 || standard::pq_eotf((p.signal16 + 1) / 65535.0) > peak));
      const CarriedLightLevel carried = carried_light_level({light, light / 4}, t.mastering());
      if (light <= peak * (1 + slack(m.mode)) && largest && sample_ok && carried.max_cll_nits <= t.mastering().max_nits) continue;
      ++failures;
      ADD_FAILURE() << to_string(m.mode) << " " << to_string(m.range) << " peak " << peak << ": clip code " << p.code
                    << " = " << light << " cd/m2" << (largest ? "" : " (not the largest at or below the peak)")
                    << ", 16-bit " << p.signal16 << ", carried MaxCLL " << carried.max_cll_nits;
    }
    EXPECT_EQ(failures, 0) << to_string(m.mode);
  }
}

// The CPU encoders end to end (threads 1; the clip curve takes the staged per-channel path,
// the default curve the fused SIMD kernel) at every 97th peak and the two the issue names:
// the brightest code written for light at and above the peak decodes to at most the peak,
// and the carried MaxCLL is within the mastering maximum.
TEST(PeakCode, CpuEncodersNeverWriteACodeAboveThePeak) {
  std::vector<double> peaks{150, 426.856, 10000};
  for (int p = 100; p <= 10000; p += 97) peaks.push_back(p);
  for (const auto& m : kModes)
    for (const char* curve : {"clip", ""})
      for (const double peak : peaks) {
        EncodeSettings s;
        s.target = target(m, peak);
        s.tone.curve = curve;
        s.threads = 1;
        const Image img = ramp_around(peak);
        SceneInput in;
        in.image = &img;
        in.units = InputUnits::absolute;
        in.white_luminance_nits = 1.0;
        auto f = encode_frame(in, s);
        ASSERT_TRUE(f.ok()) << f.error().message;
        const int code = brightest_code(*f);
        const CarriedLightLevel carried = carried_light_level(f->content_light, f->mastering);
        EXPECT_LE(decoded_nits(s.target, code), peak * (1 + slack(m.mode)))
            << to_string(m.mode) << " " << to_string(m.range) << " " << curve << " peak " << peak << ": code " << code;
        EXPECT_LE(carried.max_cll_nits, f->mastering.max_nits) << peak;
        for (std::uint16_t v : f->signal16)
          if (m.mode == Mode::hdr10 && m.range == Range::full) {
            EXPECT_LE(standard::pq_eotf(v / 65535.0), peak * (1 + 1e-12)) << peak;
          }
      }
}

TEST(PeakCode, FractionalPeakFromAnEdid) {
  // AOC 2702's EDID: peak 426.856 cd/m2 gave code 675 = 427.93 cd/m2 and MaxCLL 428.
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.target.peak_nits = 426.856;
  s.tone.curve = "clip";
  s.threads = 1;
  const Image img = ramp_around(s.target.peak_nits);
  SceneInput in;
  in.image = &img;
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  auto f = encode_frame(in, s);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(brightest_code(*f), 674);
  EXPECT_LE(standard::pq_eotf(674 / 1023.0), 426.856);
  EXPECT_GT(standard::pq_eotf(675 / 1023.0), 426.856);
  const CarriedLightLevel carried = carried_light_level(f->content_light, f->mastering);
  EXPECT_EQ(carried.max_cll_nits, 425);  // code 674 = 424.05 cd/m2 rounded up, not 428
  // The 16-bit PNG samples of the peak decode to at most it, too.
  ASSERT_FALSE(f->signal16.empty());
  for (std::uint16_t v : f->signal16) EXPECT_LE(standard::pq_eotf(v / 65535.0), 426.856 * (1 + 1e-12));
}

}  // namespace

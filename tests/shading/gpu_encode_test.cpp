// The GPU encode pass against the CPU encoder (the oracle) on rendered scenes: every
// code value within 1, in every output mode the GPU program supports.
#include <gtest/gtest.h>

#include <cstring>

#include "shading/gpu_encode.hpp"
#include "tests/shading/render_testing.hpp"
#include "tests/testing/standards.hpp"

namespace hdrd::shading {
namespace {

struct Case {
  const char* scene;
  Mode mode;
  int bits;
  const char* curve;  // "" = the mode's default
};
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.scene << " " << to_string(c.mode) << " " << c.bits << "-bit" << (*c.curve ? " " : "") << c.curve;
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string n = std::string(info.param.scene) + "_" + std::string(to_string(info.param.mode)) + "_" +
                  std::to_string(info.param.bits) + (*info.param.curve ? "_" + std::string(info.param.curve) : "");
  for (auto& c : n)
    if (c == '-') c = '_';
  return n;
}

class GpuEncode : public ::testing::TestWithParam<Case> {};

// Per-channel codes of one pixel of a DRM buffer.
std::array<int, 3> codes(const EncodedFrame& f, std::size_t i) {
  std::uint32_t w;
  if (f.drm_fourcc == kDrmFormatXbgr2101010) {
    std::memcpy(&w, f.data.data() + i * 4, 4);
    return {int(w & 0x3ff), int((w >> 10) & 0x3ff), int((w >> 20) & 0x3ff)};
  }
  if (f.drm_fourcc == kDrmFormatXrgb8888) {
    const std::uint8_t* p = f.data.data() + i * 4;  // bytes B, G, R, X
    return {p[2], p[1], p[0]};
  }
  std::uint16_t h[4];  // ABGR16161616F: R, G, B, A halves; compare as ordered integers (ULPs)
  std::memcpy(h, f.data.data() + i * 8, 8);
  auto ordered = [](std::uint16_t v) { return (v & 0x8000) ? -int(v & 0x7fff) : int(v); };
  return {ordered(h[0]), ordered(h[1]), ordered(h[2])};
}

TEST_P(GpuEncode, MatchesTheCpuEncoderWithinOneCode) {
  HDRD_REQUIRE_RENDERER(renderer);
  const Case c = GetParam();
  RenderRequest q;
  q.scene = c.scene;
  q.width = 160;
  q.height = 90;
  auto frame = renderer.render(q);
  ASSERT_TRUE(frame.ok()) << frame.error().message;

  SceneInput in;
  in.image = &frame->scene_nits;
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  in.illuminance_lux = frame->dominant_illuminance_lux;
  EncodeSettings s;
  s.target = default_target(c.mode);
  s.target.bits = c.bits;
  s.threads = 1;
  s.tone.curve = c.curve;
  // SDR containers: the program clips what leaves Rec.709 (ICtCp mapping is the CPU's).
  if (s.target.is_sdr()) s.gamut = GamutMapping::clip;
  auto prepared = prepare_pipeline(in, s);
  ASSERT_TRUE(prepared.ok()) << prepared.error().message;
  auto cpu = encode_prepared(in, *prepared);
  ASSERT_TRUE(cpu.ok()) << cpu.error().message;
  auto encoder = GpuEncoder::create(renderer, *prepared);
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  auto gpu = (*encoder)->encode();
  ASSERT_TRUE(gpu.ok()) << gpu.error().message;

  const EncodedFrame& a = *cpu;
  const EncodedFrame& b = gpu->frame;
  ASSERT_EQ(a.drm_fourcc, b.drm_fourcc);
  ASSERT_EQ(a.data.size(), b.data.size());
  int worst = 0;
  std::size_t off = 0;
  for (std::size_t i = 0; i < std::size_t(q.width) * q.height; ++i) {
    const auto x = codes(a, i), y = codes(b, i);
    for (int k = 0; k < 3; ++k) {
      worst = std::max(worst, std::abs(x[k] - y[k]));
      off += x[k] != y[k];
    }
  }
  EXPECT_LE(worst, 1) << off << " channel codes differ";
  if (!a.signal16.empty() && !b.signal16.empty()) {
    ASSERT_EQ(a.signal16.size(), b.signal16.size());
    int worst16 = 0;
    for (std::size_t i = 0; i < a.signal16.size(); ++i) worst16 = std::max(worst16, std::abs(int(a.signal16[i]) - int(b.signal16[i])));
    // 16-bit PNG samples come from E' in float on the GPU: within two 10-bit codes.
    EXPECT_LE(worst16, 131);
  }
  EXPECT_NEAR(a.content_light.max_cll_nits, b.content_light.max_cll_nits, 0.02 * a.content_light.max_cll_nits + 1);
  EXPECT_NEAR(a.content_light.max_fall_nits, b.content_light.max_fall_nits, 0.02 * a.content_light.max_fall_nits + 1);
}

INSTANTIATE_TEST_SUITE_P(Modes, GpuEncode,
                         ::testing::Values(Case{"material-grid", Mode::hdr10, 10, ""}, Case{"hdr", Mode::hdr10, 10, ""},
                                           Case{"hdr", Mode::hdr10, 10, "clip"}, Case{"material-grid", Mode::hdr10, 10, "bt2390"}, Case{"hdr", Mode::hlg, 10, ""},
                                           Case{"material-grid", Mode::sdr, 8, ""}, Case{"hdr", Mode::sdr, 10, "hable"},
                                           Case{"underwater", Mode::sdr_bt1886, 8, ""}, Case{"hdr", Mode::scrgb, 16, ""},
                                           // The curves users compare (issue 31): tables on the GPU too.
                                           Case{"hdr", Mode::hdr10, 10, "spline"}, Case{"hdr", Mode::hdr10, 10, "st2094-40"},
                                           Case{"material-grid", Mode::hdr10, 10, "st2094-10"},
                                           Case{"hdr", Mode::sdr, 8, "bt2446a"}, Case{"hdr", Mode::sdr, 10, "mobius"}),
                         case_name);

// Issue 29 item 2 on the GPU path, end to end on llvmpipe: at sampled peaks (every 499th
// integer from 100 to 10 000, the two that used to carry MaxCLL above the mastering
// maximum, 150 and 426.856, and 10 000) the brightest code the GPU program writes for light
// at and above the peak decodes (ST 2084 here, tests/testing/standards.hpp) to at most the
// peak, its 16-bit PNG samples too, and the carried MaxCLL stays within the mastering
// maximum. The clip code the program receives is the CPU's (GpuProgram.ClipCodeIsThePeakCode),
// which PeakCode.ClipCodeAtEveryIntegerPeakInEveryHdrMode checks at every integer peak.
TEST(GpuEncodePeak, NoCodeDecodesAboveThePeak) {
  HDRD_REQUIRE_RENDERER(renderer);
  std::vector<double> peaks{150, 426.856, 10000};
  for (int p = 100; p <= 10000; p += 499) peaks.push_back(p);
  for (const Range range : {Range::full, Range::narrow}) {
    for (const double peak : peaks) {
      Image img(4, 1);
      const double nits[4] = {0.999 * peak, peak, 1.001 * peak, 4 * peak};
      for (int i = 0; i < 4; ++i) {
        for (int c = 0; c < 3; ++c) img.rgba[static_cast<std::size_t>(i) * 4 + c] = static_cast<float>(nits[i]);
        img.rgba[static_cast<std::size_t>(i) * 4 + 3] = 1;
      }
      SceneInput in;
      in.image = &img;
      in.units = InputUnits::absolute;
      in.white_luminance_nits = 1.0;
      EncodeSettings s;
      s.target = default_target(Mode::hdr10);
      s.target.range = range;
      s.target.peak_nits = peak;
      s.target.paper_white_nits = std::min(203.0, peak);
      s.tone.curve = "clip";
      s.threads = 1;
      auto prepared = prepare_pipeline(in, s);
      ASSERT_TRUE(prepared.ok()) << prepared.error().message;
      auto encoder = GpuEncoder::create(renderer, *prepared);
      ASSERT_TRUE(encoder.ok()) << encoder.error().message;
      auto gpu = (*encoder)->encode_image(img);
      ASSERT_TRUE(gpu.ok()) << gpu.error().message;
      const EncodedFrame& f = gpu->frame;
      int top = 0;
      for (std::size_t i = 0; i < 4; ++i)
        for (int c : codes(f, i)) top = std::max(top, c);
      const double e = range == Range::narrow ? std::clamp((top / 4.0 - 16) / 219, 0.0, 1.0) : top / 1023.0;
      EXPECT_LE(::hdrd::testing::standard::pq_eotf(e), peak * (1 + 1e-12)) << "peak " << peak << ": code " << top;
      for (std::uint16_t v : f.signal16)
        if (range == Range::full) {
          EXPECT_LE(::hdrd::testing::standard::pq_eotf(v / 65535.0), peak * (1 + 1e-12)) << peak;
        }
      const CarriedLightLevel carried = carried_light_level(f.content_light, f.mastering);
      EXPECT_LE(carried.max_cll_nits, f.mastering.max_nits) << "peak " << peak;
    }
  }
}

}  // namespace
}  // namespace hdrd::shading

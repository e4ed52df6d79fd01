// The fast encode path against the staged (reference-table) path: the fused kernel on every
// SIMD target this CPU runs.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "encode/pipeline.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/colour/transfer.hpp"

using namespace hdrd;

namespace {

std::array<int, 3> codes_at(const EncodedFrame& f, std::size_t i) {
  std::uint32_t w;
  std::memcpy(&w, f.data.data() + i * 4, 4);
  return {static_cast<int>(w & 1023), static_cast<int>((w >> 10) & 1023), static_cast<int>((w >> 20) & 1023)};
}

struct Case {
  Range range;
  bool half;  // RGBA16F input (the AVX-512 kernel splits it with word permutes), else float
};
void PrintTo(const Case& c, std::ostream* os) { *os << to_string(c.range) << (c.half ? " half" : " float"); }

class FusedKernel : public ::testing::TestWithParam<Case> {};

// Every kernel compiled into the binary that this CPU can run (scalar .. AVX-512, whose
// table lookups use 64-bit pair gathers) encodes HDR10, with a UI, within one code of the
// staged path, with the same content light: full and narrow range (whose MaxFALL sum keeps
// the table), float and half input, NaN and Inf pixels included. Odd rows stay below the
// default curve's knee (about 2x paper white), so whole vectors take the kernel's flat-ratio
// shortcut; even rows mix the knee, the shoulder and deep shadows in every vector.
TEST_P(FusedKernel, EveryCompiledTargetMatchesTheStagedPath) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> stops(-24, 7), below_knee(-24, 0.5f);
  Image img(203, 17);  // odd width: the scalar tail too
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const bool odd_row = (i / static_cast<std::size_t>(img.width)) % 2 == 1;
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = std::exp2(odd_row ? below_knee(rng) : stops(rng));
    img.rgba[i * 4 + 3] = 1;
  }
  img.rgba[0] = 0, img.rgba[1] = 0, img.rgba[2] = 0;  // true black
  img.rgba[4 * 40] = std::numeric_limits<float>::quiet_NaN();
  img.rgba[4 * 77 + 1] = std::numeric_limits<float>::infinity();
  img.rgba[4 * 150 + 2] = -std::numeric_limits<float>::infinity();
  ImageHalf half(img.width, img.height);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) {
    half.rgba[i] = detail::float_to_half(img.rgba[i]);
    img.rgba[i] = detail::half_to_float(half.rgba[i]);  // both inputs hold the same values
  }
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 40;
  overlay->height = 5;
  for (int i = 0; i < 200; ++i) overlay->rgba.insert(overlay->rgba.end(), {1.0f, 0.3f, 0.0f, (i % 3) / 2.0f});
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.target.range = GetParam().range;
  s.threads = 1;
  s.ui.overlay = overlay;
  s.ui.x = 30, s.ui.y = 6;
  SceneInput in;
  if (GetParam().half) in.half = &half;
  else in.image = &img;
  auto staged = s;
  staged.staged_only = true;
  const auto want = encode_frame(in, staged);
  ASSERT_TRUE(want.ok());
  hwy::SetSupportedTargetsForTest(0);  // all of them, whatever an earlier failure left
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
        ASSERT_LE(std::abs(a[c] - b[c]), 1) << hwy::TargetName(target) << " pixel " << i << " channel " << c
                                             << ": " << a[c] << " vs " << b[c] << " (input " << img.rgba[i * 4] << ", "
                                             << img.rgba[i * 4 + 1] << ", " << img.rgba[i * 4 + 2] << ")";
        off += a[c] != b[c];
      }
    }
    EXPECT_LT(off, static_cast<int>(img.pixel_count() * 3 / 200)) << hwy::TargetName(target);
    const int black = GetParam().range == Range::narrow ? 64 : 0;
    EXPECT_EQ(codes_at(*got, 0), (std::array<int, 3>{black, black, black})) << hwy::TargetName(target);
    EXPECT_NEAR(got->content_light.max_cll_nits, want->content_light.max_cll_nits, 1e-3) << hwy::TargetName(target);
    EXPECT_NEAR(got->content_light.max_fall_nits, want->content_light.max_fall_nits,
                want->content_light.max_fall_nits * 1e-3)
        << hwy::TargetName(target);
  }
  hwy::SetSupportedTargetsForTest(0);
}

// The HDR10 kernel drops the quantiser's upper clamp only when no code input can pass the
// table's top (16384 cd/m2): the peak plus the brightest UI light. A 10 000 cd/m2 display
// with a 10 000 cd/m2 UI over it can reach ~20 000 where the UI is translucent, so that
// frame keeps the clamped kernel: its codes still match the staged path, top code included.
TEST(FusedKernel, BrightUiOverABrightDisplayKeepsItsCodes) {
  Image img(96, 4);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const float v = std::exp2(-4.0f + 0.2f * static_cast<float>(i % 96));  // up to ~2^15 x paper white
    img.rgba[i * 4] = v, img.rgba[i * 4 + 1] = v * 0.5f, img.rgba[i * 4 + 2] = v * 0.25f, img.rgba[i * 4 + 3] = 1;
  }
  ImageHalf half(img.width, img.height);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) half.rgba[i] = detail::float_to_half(img.rgba[i]);
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 96;
  overlay->height = 2;
  for (int i = 0; i < 192; ++i) overlay->rgba.insert(overlay->rgba.end(), {1.0f, 1.0f, 1.0f, (i % 4) / 3.0f});
  for (const double peak : {1000.0, 10000.0}) {
    EncodeSettings s;
    s.target = default_target(Mode::hdr10);
    s.target.peak_nits = peak;
    s.target.ui_white_nits = 10000;
    s.threads = 1;
    s.ui.overlay = overlay;
    s.ui.y = 1;
    SceneInput in;
    in.half = &half;
    auto staged = s;
    staged.staged_only = true;
    const auto want = encode_frame(in, staged);
    const auto got = encode_frame(in, s);
    ASSERT_TRUE(want.ok() && got.ok());
    int top = 0;
    for (std::size_t i = 0; i < img.pixel_count(); ++i) {
      const auto a = codes_at(*got, i), b = codes_at(*want, i);
      for (int c = 0; c < 3; ++c) {
        ASSERT_LE(std::abs(a[c] - b[c]), 1) << "peak " << peak << " pixel " << i;
      }
      top += a[0] == 1023;
    }
    if (peak == 10000) {
      EXPECT_GT(top, 0);  // the UI over the brightest pixels reaches the top code
    }
    EXPECT_NEAR(got->content_light.max_cll_nits, want->content_light.max_cll_nits, 1e-3) << peak;
  }
}

// Tables with kinks (patched buckets, float_lut.hpp), the per-channel offset-ratio form
// and BT.2390's per-channel black lift on every compiled target: the same codes as the
// staged path within one, around the kinks and at black.
TEST(FusedKernel, KinkedTablesAndTheBlackLiftOnEveryTarget) {
  struct Curve { const char* name; tonemap::ParamValues params; };
  const Curve curves[] = {{"bt2390", {}},                                   // the corner at 1000 cd/m2
                          {"bt2390", {{"black_lift", 1}, {"source_peak_nits", 4000}}},
                          {"hable", {}},                                    // per channel, white point
                          {"day", {{"black", 0.01}}},
                          {"clip", {}}};
  for (const auto& c : curves) {
    EncodeSettings s;
    s.target = default_target(Mode::hdr10);
    s.target.black_nits = 0.05;
    s.threads = 1;
    s.tone.curve = c.name;
    s.tone.params = c.params;
    if (std::string(c.name) == "clip") s.tone.apply = tonemap::Apply::max_rgb;  // clip as a ratio table
    Image probe(1, 1);
    SceneInput pin;
    pin.image = &probe;
    auto p = prepare_pipeline(pin, s);
    ASSERT_TRUE(p.ok()) << p.error().message;
    const auto kinks = p->curve->kinks();
    ASSERT_FALSE(kinks.empty()) << c.name;
    Image img(160, 3);
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const double k = kinks[static_cast<std::size_t>(x) % kinks.size()];
        const float v = static_cast<float>(k * (1 + 2e-4 * (x / static_cast<int>(kinks.size()) - 25)));
        float* px = img.px(x, y);
        px[0] = v, px[1] = y == 0 ? v : v * 0.3f, px[2] = y == 2 ? 0.0f : v;  // grey, and colours with zeros
        px[3] = 1;
      }
    img.rgba[0] = img.rgba[1] = img.rgba[2] = 0;  // black
    SceneInput in;
    in.image = &img;
    auto staged = s;
    staged.staged_only = true;
    const auto want = encode_frame(in, staged);
    ASSERT_TRUE(want.ok());
    hwy::SetSupportedTargetsForTest(0);
    for (const auto target : hwy::SupportedAndGeneratedTargets()) {
      hwy::SetSupportedTargetsForTest(target);
      const auto got = encode_frame(in, s);
      ASSERT_TRUE(got.ok());
      for (std::size_t i = 0; i < img.pixel_count(); ++i) {
        const auto a = codes_at(*got, i), b = codes_at(*want, i);
        for (int ch = 0; ch < 3; ++ch)
          ASSERT_LE(std::abs(a[ch] - b[ch]), 1) << c.name << " " << hwy::TargetName(target) << " pixel " << i;
      }
      ASSERT_EQ(codes_at(*got, 0), codes_at(*want, 0)) << c.name << " black, " << hwy::TargetName(target);
      // 16-bit samples within two steps, except where both decode below 1e-4 cd/m2: at a black
      // point (day's) the light is ~1e-8 cd/m2, where PQ is so steep that FMA against separate
      // multiply-adds moves a sample by a few steps.
      for (std::size_t i = 0; i < got->signal16.size(); ++i) {
        const int a = got->signal16[i], b = want->signal16[i];
        if (transfer::pq_eotf(std::max(a, b) / 65535.0) < 1e-4) continue;
        ASSERT_LE(std::abs(a - b), 2) << c.name << " " << hwy::TargetName(target) << " 16-bit sample " << i;
      }
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

// The EXR dump's display light (EncodedFrame::display_nits) from the fused kernel, on every
// compiled target, for every mode it runs (HLG is staged throughout): the staged path's
// light and, where no UI is composited, the double-precision reference's, within relative
// 2^-14 (an eighth of half's rounding) + 1e-6 cd/m2. Both paths read the same tables; what
// differs is float rounding (FMA against separate multiply-adds), largest for saturated
// colours whose Rec.2020 -> Rec.709 matrix cancels (1.2e-5 relative seen).
// The frame mixes stops from deep shadow to far above the peak, saturated Rec.2020 colours
// (outside Rec.709: SDR and scRGB send them to the exact path, whose light must land in
// the dump too), NaN and Inf, an odd width (scalar tails) and a UI over part of it.
TEST(FusedKernel, DisplayLightForTheExrDumpOnEveryTarget) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> stops(-20, 8), unit(0, 1);
  Image img(141, 12);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const float v = std::exp2(stops(rng));
    const bool saturated = i % 7 == 0;
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = saturated ? v * (c == static_cast<int>(i % 3) ? 1 : 0.01f) : v * (0.3f + unit(rng));
    img.rgba[i * 4 + 3] = 1;
  }
  img.rgba[4 * 20] = std::numeric_limits<float>::quiet_NaN();
  img.rgba[4 * 33 + 2] = std::numeric_limits<float>::infinity();
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = 24;
  overlay->height = 3;
  for (int i = 0; i < 72; ++i) overlay->rgba.insert(overlay->rgba.end(), {0.9f, 0.9f, 0.2f, (i % 4) / 3.0f});
  struct ModeCase { Mode mode; Range range; double black; const char* curve; };
  const ModeCase cases[] = {{Mode::hdr10, Range::full, 0.005, ""},        {Mode::hdr10, Range::narrow, 0.005, "bt2390"},
                            {Mode::hdr10, Range::full, 0.0, "hable"},     {Mode::sdr, Range::full, 0.2, ""},
                            {Mode::sdr_bt1886, Range::full, 0.1, ""},     {Mode::sdr_bt1886, Range::narrow, 0.0, ""},
                            {Mode::scrgb, Range::full, 0.0, ""}};
  for (const auto& mc : cases) {
    for (const bool ui : {false, true}) {
      EncodeSettings s;
      s.target = default_target(mc.mode);
      s.target.range = mc.range;
      s.target.black_nits = mc.black;
      s.tone.curve = mc.curve;
      s.keep_display_nits = true;
      s.threads = 1;
      if (ui) {
        s.ui.overlay = overlay;
        s.ui.x = 37, s.ui.y = 4;
      }
      const std::string what = std::string(to_string(mc.mode)) + " " + std::string(to_string(mc.range)) + " " + mc.curve +
                               (ui ? " with UI" : "");
      SceneInput in;
      in.image = &img;
      auto staged = s;
      staged.staged_only = true;
      const auto want = encode_frame(in, staged);
      ASSERT_TRUE(want.ok()) << what;
      auto prepared = prepare_pipeline(in, s);
      ASSERT_TRUE(prepared.ok()) << what;
      hwy::SetSupportedTargetsForTest(0);
      for (const auto target : hwy::SupportedAndGeneratedTargets()) {
        hwy::SetSupportedTargetsForTest(target);
        const auto got = encode_frame(in, s);
        ASSERT_TRUE(got.ok() && got->display_nits) << what;
        for (int y = 0; y < img.height; ++y)
          for (int x = 0; x < img.width; ++x) {
            const float* a = got->display_nits->px(x, y);
            const float* b = want->display_nits->px(x, y);
            const bool under_ui = ui && y >= s.ui.y - 1 && y <= s.ui.y + overlay->height && x >= s.ui.x - 1 &&
                                  x <= s.ui.x + overlay->width;
            const float* in_px = img.px(x, y);
            const bool finite = std::isfinite(in_px[0] + in_px[1] + in_px[2]);
            const color::Vec3 ref = reference_display_nits(*prepared, {in_px[0], in_px[1], in_px[2]});
            for (int c = 0; c < 3; ++c) {
              // NaN and Inf pixels (the documented rule: 0 and 1e30): finite light; the
              // paths differ in the ~1e-6 cd/m2 a huge channel leaves in the others.
              ASSERT_TRUE(std::isfinite(a[c])) << what << " (" << x << ", " << y << ")";
              if (!finite) continue;
              ASSERT_NEAR(a[c], b[c], std::ldexp(std::abs(b[c]), -14) + 1e-6)
                  << what << " " << hwy::TargetName(target) << " (" << x << ", " << y << ") channel " << c;
              if (!under_ui) {
                ASSERT_NEAR(a[c], (&ref.x)[c], std::ldexp(std::abs((&ref.x)[c]), -14) + 1e-6)
                    << what << " " << hwy::TargetName(target) << " (" << x << ", " << y << ") channel " << c
                    << " against the reference";
              }
            }
            ASSERT_EQ(a[3], 1.0f);
          }
      }
      hwy::SetSupportedTargetsForTest(0);
    }
  }
}

// A black frame measures no light on any target: MaxFALL's fitted decode (AVX-512) dipped
// to -1.3e-5 cd/m2 at code 0, a negative frame average in the sidecar.
TEST(FusedKernel, BlackFrameMeasuresNoLightOnEveryTarget) {
  const Image black(64, 4);
  SceneInput in;
  in.image = &black;
  for (const Range range : {Range::full, Range::narrow}) {
    EncodeSettings s;
    s.target = default_target(Mode::hdr10);
    s.target.range = range;
    s.threads = 1;
    hwy::SetSupportedTargetsForTest(0);
    for (const auto target : hwy::SupportedAndGeneratedTargets()) {
      hwy::SetSupportedTargetsForTest(target);
      const auto f = encode_frame(in, s);
      ASSERT_TRUE(f.ok());
      EXPECT_EQ(f->content_light.max_cll_nits, 0.0) << hwy::TargetName(target);
      EXPECT_EQ(f->content_light.max_fall_nits, 0.0) << hwy::TargetName(target);
    }
    hwy::SetSupportedTargetsForTest(0);
  }
}

INSTANTIATE_TEST_SUITE_P(Inputs, FusedKernel,
                         ::testing::Values(Case{Range::full, false}, Case{Range::full, true}, Case{Range::narrow, false},
                                           Case{Range::narrow, true}),
                         [](const auto& i) {
                           return std::string(i.param.range == Range::full ? "full" : "narrow") +
                                  (i.param.half ? "_half" : "_float");
                         });

}  // namespace

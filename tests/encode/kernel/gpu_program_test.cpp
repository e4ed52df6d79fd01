// The GPU program description (no GL here; tests/shading runs it on llvmpipe).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "encode/kernel/constants.hpp"
#include "encode/kernel/gpu_program.hpp"
#include "encode/kernel/pipeline_internal.hpp"

using namespace hdrd;

namespace {

PreparedPipeline prepare(Mode m, const std::string& curve, Image& img, const tonemap::ParamValues& params = {},
                         GamutMapping gamut = GamutMapping::ictcp) {
  EncodeSettings s;
  s.target = default_target(m);
  s.tone.curve = curve;
  s.tone.params = params;
  // SDR containers take gamut clip here: ICtCp mapping into Rec.709 runs on the CPU
  // (GpuProgram.SdrIctcpGamutMappingStaysOnTheCpu).
  s.gamut = s.target.is_sdr() && gamut == GamutMapping::ictcp ? GamutMapping::clip : gamut;
  SceneInput in;
  in.image = &img;
  return prepare_pipeline(in, s).value();
}

TEST(GpuProgram, TablesAreTheCpuTablesAndFitATextureRow) {
  Image img(2, 2);
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::sdr, Mode::sdr_bt1886, Mode::scrgb}) {
    const auto p = prepare(m, "pq-shoulder", img);
    const auto prog = gpu::make_encode_program(p);
    ASSERT_TRUE(prog.supported) << prog.unsupported_reason;
    EXPECT_NE(prog.glsl.find("uvec4 hdrd_encode(vec3 rgb, ivec2 pixel)"), std::string::npos);
    EXPECT_NE(prog.glsl.find("layout(std140, binding = 3) uniform HdrdEncode"), std::string::npos);
    for (const auto& t : prog.tables) {
      EXPECT_LE(t.data.size(), 16384u) << t.sampler;
      EXPECT_NE(prog.glsl.find(t.sampler), std::string::npos);
    }
    EXPECT_EQ(prog.tables.size(), m == Mode::scrgb ? 1u : 2u);
    EXPECT_FLOAT_EQ(prog.uniforms.paper_white, static_cast<float>(p.settings.target.paper_white_nits));
    // mat3 column 0 = first column of (to_working * scene_scale).
    EXPECT_FLOAT_EQ(prog.uniforms.m_in[1], static_cast<float>(p.input_to_working.m[1][0] * p.scene_scale));
  }
}

// The program takes its constants from the colour code (encode/kernel/constants.hpp): the
// Rec.2020 luminance weights, scRGB's 80 cd/m2 and the 16-bit scale are printed once, at
// full float precision, and never written as literals in the generated code.
TEST(GpuProgram, ConstantsComeFromTheColourCode) {
  Image img(2, 2);
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::sdr, Mode::scrgb}) {
    const auto prog = gpu::make_encode_program(prepare(m, "pq-shoulder", img));
    ASSERT_TRUE(prog.supported) << prog.unsupported_reason;
    EXPECT_EQ(prog.glsl.find(kernel::glsl_constants()), prog.glsl.find("const vec3 kLuma")) << "the block, once";
    for (const char* literal : {"0.2627", "0.6780", "0.0593", "80.0", "1023.0", "65535.0"})
      EXPECT_EQ(prog.glsl.find(literal), std::string::npos) << literal << " written as a literal in " << to_string(m);
  }
  // The block says what the colour code says.
  const std::string block = kernel::glsl_constants();
  EXPECT_NE(block.find(fmt::format("{:.9e}", static_cast<float>(color::kRec2020Luma.y))), std::string::npos) << block;
  EXPECT_NE(block.find(fmt::format("{:.9e}", static_cast<float>(1.0 / transfer::kScrgbUnitNits))), std::string::npos);
  EXPECT_FLOAT_EQ(kernel::rec2020_luminance(1, 1, 1), 1.0f);
}

TEST(GpuProgram, SdrIctcpGamutMappingStaysOnTheCpu) {
  Image img(2, 2);
  EncodeSettings s;
  s.target = default_target(Mode::sdr);
  SceneInput in;
  in.image = &img;
  const auto prog = gpu::make_encode_program(prepare_pipeline(in, s).value());
  EXPECT_FALSE(prog.supported);
  EXPECT_NE(prog.unsupported_reason.find("gamut"), std::string::npos) << prog.unsupported_reason;
}

// The gamut-mapping family: this program only clips, so it takes a map only where nothing
// needs mapping (the Rec.2020 container of hdr10/hlg, from an input that fits); into an SDR
// container the map runs on the CPU and says so. The new curves are tables: they run here.
TEST(GpuProgram, GamutMapsRunWhereNothingNeedsMapping) {
  Image img(2, 2);
  for (std::string_view n : kGamutMappingNames) {
    const GamutMapping g = *parse_gamut_mapping(n);
    if (g == GamutMapping::ictcp || g == GamutMapping::clip) continue;
    const auto sdr = gpu::make_encode_program(prepare(Mode::sdr, "pq-shoulder", img, {}, g));
    EXPECT_FALSE(sdr.supported) << n;
    EXPECT_NE(sdr.unsupported_reason.find(fmt::format("gamut mapping '{}'", n)), std::string::npos) << sdr.unsupported_reason;
    for (Mode m : {Mode::hdr10, Mode::hlg}) {
      const auto hdr = gpu::make_encode_program(prepare(m, "pq-shoulder", img, {}, g));
      EXPECT_TRUE(hdr.supported) << n << " " << to_string(m) << ": " << hdr.unsupported_reason;
    }
  }
  for (const char* c : {"spline", "bt2446a", "st2094-40", "st2094-10", "mobius"}) {
    const auto prog = gpu::make_encode_program(prepare(Mode::hdr10, c, img));
    EXPECT_TRUE(prog.supported) << c << ": " << prog.unsupported_reason;
  }
}

TEST(GpuProgram, RgbOperatorsAndGradesStayOnTheCpu) {
  Image img(2, 2);
  for (const char* c : {"agx", "pbr-neutral", "ictcp"}) {
    const auto prog = gpu::make_encode_program(prepare(Mode::hdr10, c, img));
    EXPECT_FALSE(prog.supported) << c;
    EXPECT_NE(prog.unsupported_reason.find(c), std::string::npos);
  }
  EXPECT_TRUE(gpu::make_encode_program(prepare(Mode::hdr10, "clip", img)).supported);
  // Curves applied to luminance may leave the gamut: the CPU gamut-maps them.
  for (const char* c : {"reinhard", "drago"}) {
    const auto prog = gpu::make_encode_program(prepare(Mode::hdr10, c, img));
    EXPECT_FALSE(prog.supported) << c;
    EXPECT_NE(prog.unsupported_reason.find("luminance"), std::string::npos) << prog.unsupported_reason;
  }
}

// The program carries what the CPU tables carry: each kink's patch (with the CPU's own
// constants), the per-channel offset-ratio form, BT.2390's black lift table, and the HLG
// volume fit (only with ictcp gamut mapping; clip clips E per channel). tests/shading runs
// these on llvmpipe against the CPU encoder.
TEST(GpuProgram, KinksBlackLiftAndHlgVolumeAreInTheProgram) {
  Image img(2, 2);
  const auto corner = gpu::make_encode_program(prepare(Mode::hdr10, "bt2390", img));  // source 1000 on 1000
  ASSERT_TRUE(corner.supported) << corner.unsupported_reason;
  EXPECT_NE(corner.glsl.find("if (i == "), std::string::npos) << "the corner's patch";
  const auto lift = gpu::make_encode_program(prepare(Mode::hdr10, "bt2390", img, {{"black_lift", 1}}));
  ASSERT_TRUE(lift.supported);
  EXPECT_EQ(lift.tables.size(), 3u);
  EXPECT_NE(lift.glsl.find("hdrd_lift(nits.r)"), std::string::npos);
  EXPECT_GT(lift.uniforms.lift_zero, 0.0f);
  const auto per_channel = gpu::make_encode_program(prepare(Mode::hdr10, "hable", img));
  EXPECT_NE(per_channel.glsl.find("hdrd_u.toes.x + w * hdrd_u.toes.y"), std::string::npos);
  const auto hlg = gpu::make_encode_program(prepare(Mode::hlg, "pq-shoulder", img));
  EXPECT_NE(hlg.glsl.find("float room = 1.0 / kk - yd"), std::string::npos);
  const auto hlg_clip = gpu::make_encode_program(prepare(Mode::hlg, "pq-shoulder", img, {}, GamutMapping::clip));
  EXPECT_EQ(hlg_clip.glsl.find("float room"), std::string::npos);
}

TEST(GpuProgram, ReadbackBuildsTheFrameAndMeasuresLight) {
  Image img(2, 1);
  const auto p = prepare(Mode::hdr10, "clip", img);
  auto prog = gpu::make_encode_program(p);
  prog.target_format = gpu::TargetFormat::r32ui;
  // Two pixels, bottom-up rows: codes 594 (203 cd/m2) and 769 (1000 cd/m2) grey.
  auto word = [](std::uint32_t c) { return c | (c << 10) | (c << 20) | (3u << 30); };
  const std::uint32_t px[2] = {word(594), word(769)};
  auto f = gpu::frame_from_readback(p, prog, 2, 1, px, true);
  ASSERT_TRUE(f.ok());
  EXPECT_NEAR(f->content_light.max_cll_nits, 1000, 1.5);
  EXPECT_NEAR(f->content_light.max_fall_nits, (1000 + 203) / 2.0, 1.5);
}

// Issue 29 item 2: the clip code the GPU program receives (bases.z) and its 16-bit sample
// limit are the CPU's (detail::peak_codes, checked at every integer peak from 100 to
// 10 000 against ST 2084 in tests/encode/peak_code_test.cpp), at every 97th peak in both
// ranges; and they decode (ST 2084 computed here) to at most the peak. The program's output:
// tests/shading/gpu_encode_test.cpp (GpuEncodePeak).
TEST(GpuProgram, ClipCodeIsThePeakCode) {
  auto pq_eotf = [](double e) {
    const double m1 = 2610.0 / 16384, m2 = 2523.0 / 4096 * 128, c1 = 3424.0 / 4096, c2 = 2413.0 / 4096 * 32,
                 c3 = 2392.0 / 4096 * 32;
    const double p = std::pow(std::clamp(e, 0.0, 1.0), 1 / m2);
    return 10000 * std::pow(std::max(p - c1, 0.0) / (c2 - c3 * p), 1 / m1);
  };
  Image img(1, 1);
  for (const Range range : {Range::full, Range::narrow}) {
    auto decode = [&](int code) {
      return pq_eotf(range == Range::narrow ? std::clamp((code / 4.0 - 16) / 219, 0.0, 1.0) : code / 1023.0);
    };
    for (int peak = 100; peak <= 10000; peak += 97) {
      EncodeSettings s;
      s.target = default_target(Mode::hdr10);
      s.target.range = range;
      s.target.peak_nits = peak;
      s.target.paper_white_nits = std::min(203, peak);
      s.tone.curve = "clip";
      SceneInput in;
      in.image = &img;
      const auto prog = gpu::make_encode_program(prepare_pipeline(in, s).value());
      ASSERT_TRUE(prog.supported) << prog.unsupported_reason;
      const auto want = detail::peak_codes(s.target);
      EXPECT_EQ(static_cast<int>(prog.uniforms.max_code), want.code) << peak;
      EXPECT_LE(decode(static_cast<int>(prog.uniforms.max_code)), peak * (1 + 1e-12)) << peak;
      if (range == Range::full) {
        EXPECT_EQ(std::lround(prog.uniforms.signal_max * 65535.0), want.signal16) << peak;
        EXPECT_LE(pq_eotf(std::lround(prog.uniforms.signal_max * 65535.0) / 65535.0), peak * (1 + 1e-12)) << peak;
      }
    }
  }
}

}  // namespace

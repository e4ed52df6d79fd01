// The generic GPU post pass: identity to RGBA32F, exact integer codes through
// GL_RGB10_A2UI, exact halves through packHalf2x16 into GL_RGBA16UI, highp 1D/2D/3D
// float tables, std140 blocks checked against their C++ twins. The CPU is the oracle.
#include <gtest/gtest.h>

#include <cstring>

#include "shading/gpu_pass.hpp"
#include "tests/shading/render_testing.hpp"

namespace hdrd::shading {
namespace {

// Reference float -> binary16, round to nearest even (IEEE 754), for finite inputs.
std::uint16_t half_rne(float f) {
  std::uint32_t x;
  std::memcpy(&x, &f, 4);
  const std::uint32_t sign = (x >> 16) & 0x8000u;
  const float a = std::fabs(f);
  if (a >= 65520.0f) return static_cast<std::uint16_t>(sign | 0x7c00u);  // overflow to infinity
  if (a < 6.103515625e-05f) {  // subnormal: multiples of 2^-24
    const auto q = static_cast<std::uint32_t>(std::nearbyint(a * 16777216.0f));
    return static_cast<std::uint16_t>(sign | q);
  }
  int e;
  const float m = std::frexp(a, &e);  // a = m 2^e, m in [0.5, 1)
  auto mant = static_cast<std::uint32_t>(std::nearbyint((m * 2 - 1) * 1024.0f));
  int exp = e - 1 + 15;
  if (mant == 1024) { mant = 0; ++exp; }
  return static_cast<std::uint16_t>(sign | (static_cast<std::uint32_t>(exp) << 10) | mant);
}

struct Scale {  // std140 twin of `uniform Params { vec4 gain; vec4 offset; }`
  float gain[4];
  float offset[4];
};
static_assert(sizeof(Scale) == 32);

TEST(GpuPass, IdentityReadsTheRenderedFrameExactly) {
  HDRD_REQUIRE_RENDERER(renderer);
  RenderRequest q;
  q.scene = "underwater";
  q.width = 64;
  q.height = 40;
  auto frame = renderer.render(q);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  PassProgram p;
  p.name = "identity";
  p.fragment_source = R"(
void main() { hdrd_out = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0) * hdrd_scene_scale; }
)";
  p.block_name.clear();
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_TRUE(pass.ok()) << pass.error().message;
  auto out = (*pass)->run({});
  ASSERT_TRUE(out.ok()) << out.error().message;
  ASSERT_EQ(out->width, 64);
  ASSERT_EQ(out->bytes.size(), 64u * 40 * 16);
  for (std::size_t i = 0; i < frame->scene_nits.rgba.size(); i += 4)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(out->floats()[i + c], frame->scene_nits.rgba[i + c]) << i / 4;
}

TEST(GpuPass, QuantisesExactlyThroughAnIntegerTarget) {
  HDRD_REQUIRE_RENDERER(renderer);
  // platform-debian12.md §1: 2,274 of 10,240 values were 1 code off through GL_RGB10_A2;
  // codes computed in the shader into GL_RGB10_A2UI must match round(v * 1023) exactly.
  Image ramp(128, 80);
  for (std::size_t i = 0; i < ramp.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) ramp.rgba[i * 4 + c] = float((i * 3 + c) % 10240) / 10239.0f;
  PassProgram p;
  p.name = "quantise";
  p.output = PassOutput::rgb10a2ui;
  p.block_size = sizeof(Scale);
  p.fragment_source = R"(
layout(std140, binding = 3) uniform Params { vec4 gain; vec4 offset; };
void main() {
  vec4 v = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0) * gain + offset;
  hdrd_out = uvec4(hdrd_quantize(v, 1023.0).rgb, 3u);
}
)";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_TRUE(pass.ok()) << pass.error().message;
  const Scale identity{{1, 1, 1, 1}, {0, 0, 0, 0}};
  auto out = (*pass)->run_on_image(ramp, block_bytes(identity));
  ASSERT_TRUE(out.ok()) << out.error().message;
  int mismatches = 0;
  for (std::size_t i = 0; i < ramp.pixel_count(); ++i) {
    const std::uint32_t w = out->word(i);  // XBGR2101010: R in bits 0-9
    for (int c = 0; c < 3; ++c) {
      const auto want = static_cast<std::uint32_t>(std::lround(double(ramp.rgba[i * 4 + c]) * 1023.0));
      mismatches += ((w >> (10 * c)) & 0x3ffu) != want;
    }
    EXPECT_EQ(w >> 30, 3u);
  }
  EXPECT_EQ(mismatches, 0);
  // The uniform block reaches the shader: gain 0, offset 0.5 -> code 512 everywhere.
  const Scale half{{0, 0, 0, 0}, {0.5f, 0.5f, 0.5f, 0.5f}};
  out = (*pass)->run_on_image(ramp, block_bytes(half));
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->word(0) & 0x3ffu, 512u);
  EXPECT_EQ(out->word(ramp.pixel_count() - 1) & 0x3ffu, 512u);
}

TEST(GpuPass, WritesHalvesRoundedToNearestEven) {
  HDRD_REQUIRE_RENDERER(renderer);
  // llvmpipe's float->half store rounds toward zero (1.000732 -> 0x3C00); packHalf2x16
  // rounds to nearest even (0x3C01) and overflows to infinity.
  Image img(64, 4);
  const float specials[] = {1.000732f, 0.001f, 70000.0f, -0.5f, 65504.0f, 6.1e-5f, 1e-7f, 0.0f};
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < 4; ++c)
      img.rgba[i * 4 + c] = i < 8 ? specials[i] : std::ldexp(1.0f + float((i * 4 + c) * 37 % 1000) / 1000.0f, int(i % 30) - 15);
  PassProgram p;
  p.name = "halves";
  p.output = PassOutput::rgba16f_bits;
  p.block_name.clear();
  p.fragment_source = R"(
void main() {
  vec4 v = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0);
  hdrd_out = uvec4(hdrd_half_bits(v.r), hdrd_half_bits(v.g), hdrd_half_bits(v.b), hdrd_half_bits(v.a));
}
)";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_TRUE(pass.ok()) << pass.error().message;
  auto out = (*pass)->run_on_image(img, {});
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->half(0, 0), 0x3C01);
  EXPECT_EQ(out->half(1, 0), 0x1419);
  EXPECT_EQ(out->half(2, 0), 0x7C00);
  for (std::size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < 4; ++c) ASSERT_EQ(out->half(i, c), half_rne(img.rgba[i * 4 + c])) << "pixel " << i << " channel " << c;
}

TEST(GpuPass, HighpTablesIn1D2DAnd3D) {
  HDRD_REQUIRE_RENDERER(renderer);
  // A 4096-entry 1D table and a 17^3 3D table, linearly filtered; lowp samplers would
  // quantise to fp16 on llvmpipe (3.6e-4 error, platform-debian12.md §3).
  PassTexture curve;
  curve.sampler = "u_curve";
  curve.dimensions = 1;
  curve.width = 4096;
  curve.channels = 1;
  for (int i = 0; i < 4096; ++i) curve.data.push_back(std::sqrt(i / 4095.0f) + 1.0f);
  PassTexture cube;
  cube.sampler = "u_cube";
  cube.dimensions = 3;
  cube.width = cube.height = cube.depth = 17;
  cube.channels = 3;
  for (int b = 0; b < 17; ++b)
    for (int g = 0; g < 17; ++g)
      for (int r = 0; r < 17; ++r) cube.data.insert(cube.data.end(), {r / 16.0f + 0.1f, g / 16.0f, 1.0f - b / 16.0f});
  PassProgram p;
  p.name = "tables";
  p.block_name.clear();
  p.textures = {curve, cube};
  p.fragment_source = R"(
uniform sampler2D u_curve;
uniform sampler3D u_cube;
void main() {
  vec4 v = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0);
  float x = (v.r * 4095.0 + 0.5) / 4096.0;            // table coordinate of entry v.r * 4095
  vec3 c = (v.gba * 16.0 + 0.5) / 17.0;
  hdrd_out = vec4(texture(u_curve, vec2(x, 0.5)).r, texture(u_cube, c).rgb);
}
)";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_TRUE(pass.ok()) << pass.error().message;
  Image img(32, 32);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    img.rgba[i * 4] = float(i) / 1023.0f;
    img.rgba[i * 4 + 1] = float(i % 17) / 16.0f;
    img.rgba[i * 4 + 2] = float((i / 17) % 17) / 16.0f;
    img.rgba[i * 4 + 3] = 0.37f;  // between grid points: a trilinear blend
  }
  auto out = (*pass)->run_on_image(img, {});
  ASSERT_TRUE(out.ok()) << out.error().message;
  double worst_curve = 0;
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const double pos = img.rgba[i * 4] * 4095.0;
    const int k = std::min(4094, int(pos));
    const double t = pos - k;
    const double want = curve.data[k] * (1 - t) + curve.data[k + 1] * t;
    worst_curve = std::max(worst_curve, std::abs(out->floats()[i * 4] - want));
    EXPECT_NEAR(out->floats()[i * 4 + 1], img.rgba[i * 4 + 1] + 0.1, 2e-6);
    EXPECT_NEAR(out->floats()[i * 4 + 2], img.rgba[i * 4 + 2], 2e-6);
    EXPECT_NEAR(out->floats()[i * 4 + 3], 1.0 - 0.37, 2e-6);
  }
  // Filtering weights have 8 fractional bits on llvmpipe (GL allows that): one table step
  // here is <= 2.2e-2, so the weight error is below 1e-4, far under fp16's 1e-3 near 2.
  EXPECT_LT(worst_curve, 1e-4);
}

TEST(GpuPass, BlockSizeMustMatchItsCppTwin) {
  HDRD_REQUIRE_RENDERER(renderer);
  PassProgram p;
  p.name = "mismatch";
  p.block_size = 16;  // the shader's block is 32 bytes
  p.fragment_source = R"(
layout(std140, binding = 3) uniform Params { vec4 gain; vec4 offset; };
void main() { hdrd_out = gain + offset; }
)";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_FALSE(pass.ok());
  EXPECT_NE(pass.error().message.find("32 bytes in GLSL, 16 in C++"), std::string::npos) << pass.error().message;
}

TEST(GpuPass, ShaderErrorsCarryTheDriverLog) {
  HDRD_REQUIRE_RENDERER(renderer);
  PassProgram p;
  p.name = "broken";
  p.block_name.clear();
  p.fragment_source = "void main() { hdrd_out = undefined_thing; }\n";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_FALSE(pass.ok());
  EXPECT_NE(pass.error().message.find("broken fragment shader does not compile"), std::string::npos) << pass.error().message;
  EXPECT_NE(pass.error().message.find("undefined_thing"), std::string::npos) << pass.error().message;
}

TEST(GpuPass, WrongUniformSizeIsAnError) {
  HDRD_REQUIRE_RENDERER(renderer);
  PassProgram p;
  p.name = "sized";
  p.block_size = sizeof(Scale);
  p.fragment_source = R"(
layout(std140, binding = 3) uniform Params { vec4 gain; vec4 offset; };
void main() { hdrd_out = gain + offset; }
)";
  auto pass = GpuPass::compile(renderer, p);
  ASSERT_TRUE(pass.ok()) << pass.error().message;
  Image img(4, 4);
  const float too_small[4] = {};
  auto out = (*pass)->run_on_image(img, std::as_bytes(std::span(too_small)));
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.error().message.find("16 uniform bytes given"), std::string::npos) << out.error().message;
}

TEST(GpuPass, IntegerReadbackOnGlesMatchesDesktop) {
  HDRD_REQUIRE_RENDERER(renderer);
  // GLES reads integer targets only as RGBA_INTEGER/UNSIGNED_INT: the pass repacks them.
  auto gles = Renderer::create(ContextOptions{Backend::egl, GlFlavor::gles});
  auto desktop = Renderer::create(ContextOptions{Backend::egl, GlFlavor::desktop});
  if (!gles || !desktop) GTEST_SKIP() << "needs GLES 3.2 and GL 4.5 core";
  Image img(40, 30);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = float(i % 997) / 996.0f;
  const PassOutput outputs[] = {PassOutput::rgb10a2ui, PassOutput::rgba16f_bits, PassOutput::rgba8ui,
                                PassOutput::r32ui, PassOutput::rg32ui, PassOutput::rgba32ui};
  for (PassOutput o : outputs) {
    PassProgram p;
    p.name = "repack";
    p.block_name.clear();
    p.output = o;
    p.fragment_source = R"(
void main() {
  vec4 v = texelFetch(hdrd_scene, ivec2(gl_FragCoord.xy), 0);
  uvec4 q = hdrd_quantize(v, 1023.0);
  ivec2 px = hdrd_pixel();
  hdrd_out = uvec4(q.r | (q.g << 10) | (uint(px.y) << 20), hdrd_half_bits(v.g), q.b & 255u, q.a & 3u);
}
)";
    std::vector<std::uint8_t> bytes[2];
    int k = 0;
    for (auto* r : {gles->get(), desktop->get()}) {
      auto pass = GpuPass::compile(*r, p);
      ASSERT_TRUE(pass.ok()) << pass.error().message;
      auto out = (*pass)->run_on_image(img, {});
      ASSERT_TRUE(out.ok()) << out.error().message;
      bytes[k++] = out->bytes;
    }
    EXPECT_EQ(bytes[0], bytes[1]) << "output " << int(o);
  }
  // hdrd_pixel() counts rows top-down: the first row read back is row 0.
  PassProgram p;
  p.name = "rows";
  p.block_name.clear();
  p.output = PassOutput::r32ui;
  p.fragment_source = "void main() { hdrd_out = uvec4(uint(hdrd_pixel().y), 0u, 0u, 0u); }\n";
  auto pass = GpuPass::compile(**gles, p);
  ASSERT_TRUE(pass.ok());
  auto out = (*pass)->run_on_image(img, {});
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->word(0), 0u);
  EXPECT_EQ(out->word(img.pixel_count() - 1), 29u);
}

}  // namespace
}  // namespace hdrd::shading

#include "encode/kernel/gpu_program.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>

#include <fmt/format.h>

#include "encode/kernel/pipeline_internal.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::gpu {

using color::Mat3;
using detail::ToneKind;

static_assert(sizeof(EncodeUniforms) == 224, "std140 HdrdEncode is 224 bytes");
static_assert(offsetof(EncodeUniforms, m_container) == 48);
static_assert(offsetof(EncodeUniforms, paper_white) == 96);
static_assert(offsetof(EncodeUniforms, tone_lo) == 112);
static_assert(offsetof(EncodeUniforms, signal_hi_prev) == 128);
static_assert(offsetof(EncodeUniforms, tone_base) == 144);
static_assert(offsetof(EncodeUniforms, ui_x0) == 160);
static_assert(offsetof(EncodeUniforms, ui_w) == 176);
static_assert(offsetof(EncodeUniforms, tone_zero) == 192);
static_assert(offsetof(EncodeUniforms, lift_lo) == 208);

namespace {

// The GLSL twin of EncodeUniforms (std140: mat3 = three vec4 columns).
constexpr const char* kBlock = R"(layout(std140, binding = 3) uniform HdrdEncode {
  mat3 m_in;
  mat3 m_container;
  vec4 levels;      // paper_white, peak, code_scale, code_offset
  vec4 tone_range;  // tone_lo, tone_hi_prev, tone_hi, signal_lo
  vec4 misc;        // signal_hi_prev, hlg_peak, hlg_gamma, ui_dim
  uvec4 bases;      // tone_base, signal_base, max_code (the peak's code), lift_base
  vec4 ui_place;    // ui_x0, ui_y0, ui_scale, gamut_lo
  ivec4 ui_size;    // ui_w, ui_h, -, -
  vec4 toes;        // tone_zero, tone_toe_slope, lift_zero, lift_toe_slope
  vec4 lift_range;  // lift_lo, lift_hi_prev, signal_max, -
} hdrd_u;
)";

// Mirrors FloatBitsLut::operator() (float_lut.hpp): index from the float's bits,
// linear interpolation in the bucket; each table's wrapper adds its kinks' hats
// (lut_function below), whose constants come from FloatBitsLut::patches().
constexpr const char* kLut = R"(float hdrd_lut(highp sampler2D t, uint base_bits, float lo, float hi_prev, float v,
               out int i, out float f) {
  v = clamp(v, lo, hi_prev);
  uint rel = floatBitsToUint(v) - base_bits;
  i = int(rel >> %SHIFT%u);
  f = float(rel & %MASK%u) * %INV%;
  float a = texelFetch(t, ivec2(i, 0), 0).r;
  float b = texelFetch(t, ivec2(i + 1, 0), 0).r;
  return a + (b - a) * f;
}
)";

std::string glsl_float(double v) { return fmt::format("{:.9e}", v); }

// `float NAME(float v)`: the lookup of one table with its patches baked in.
std::string lut_function(const std::string& name, const std::string& sampler, const std::string& args,
                         const FloatBitsLut& l) {
  std::string g = fmt::format("uniform highp sampler2D {};\nfloat {}(float v) {{\n  int i; float f;\n"
                              "  float r = hdrd_lut({}, {}, v, i, f);\n",
                              sampler, name, sampler, args);
  for (const auto& p : l.patches())
    g += fmt::format("  if (i == {}) r += {} * max(0.0, min((f - {}) * {}, ({} - f) * {}));\n", p.bucket,
                     glsl_float(p.delta), glsl_float(p.left), glsl_float(p.inv_left), glsl_float(p.right),
                     glsl_float(p.inv_right));
  return g + "  return r;\n}\n";
}

// Mirrors sample_ui() in encode_frame.cpp: bilinear on premultiplied container nits.
constexpr const char* kUi = R"(vec4 hdrd_ui_sample(ivec2 p) {
  float u = (float(p.x) + 0.5 - hdrd_u.ui_place.x) / hdrd_u.ui_place.z - 0.5;
  float v = (float(p.y) + 0.5 - hdrd_u.ui_place.y) / hdrd_u.ui_place.z - 0.5;
  ivec2 size = hdrd_u.ui_size.xy;
  if (u < -0.5 || v < -0.5 || u > float(size.x) - 0.5 || v > float(size.y) - 0.5) return vec4(0.0);
  float fu = floor(u), fv = floor(v);
  float tu = u - fu, tv = v - fv;
  ivec2 b = ivec2(int(fu), int(fv));
  vec4 s = vec4(0.0);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      ivec2 q = clamp(b + ivec2(i, j), ivec2(0), size - 1);
      float w = (i == 1 ? tu : 1.0 - tu) * (j == 1 ? tv : 1.0 - tv);
      s += w * texelFetch(hdrd_ui, q, 0);
    }
  return s;
}
)";

void fill_mat(float* dst, const Mat3& m) {
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 4; ++r) dst[c * 4 + r] = r < 3 ? static_cast<float>(m.m[r][c]) : 0.0f;
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t pos = 0; (pos = s.find(from, pos)) != std::string::npos; pos += to.size()) s.replace(pos, from.size(), to);
  return s;
}

std::string tone_glsl(const detail::ToneStage& t, bool container_max) {
  switch (t.kind) {
    case ToneKind::clip:
      return "  vec3 nits = min(w * hdrd_u.levels.x, vec3(hdrd_u.levels.y));\n";
    case ToneKind::per_channel:
      // ToneStage's toe: f(0) + x slope below the table's bottom (toe_lookup).
      return "  vec3 nits = mix(vec3(hdrd_tone(w.r), hdrd_tone(w.g), hdrd_tone(w.b)), hdrd_u.toes.x + w * hdrd_u.toes.y,\n"
             "                 lessThan(w, vec3(hdrd_u.tone_range.x)));\n";
    case ToneKind::ratio: {
      std::string s = t.ratio_of_luminance ? "  float k = dot(kLuma, w);\n"
                                           : "  float k = max(max(w.r, w.g), w.b);\n";
      if (container_max && !t.ratio_of_luminance) {
        s += "  vec3 wc = hdrd_u.m_container * w;\n  k = max(k, max(max(wc.r, wc.g), wc.b));\n";
      }
      s += "  float ratio = k > 0.0 ? hdrd_tone(k) * min(1.0, hdrd_u.tone_range.z / k) : 0.0;\n"
           "  vec3 nits = w * ratio;\n";
      if (t.has_lift)
        s += "  nits = mix(vec3(hdrd_lift(nits.r), hdrd_lift(nits.g), hdrd_lift(nits.b)), hdrd_u.toes.z + nits * hdrd_u.toes.w,\n"
             "             lessThan(nits, vec3(hdrd_u.lift_range.x)));\n";
      return s;
    }
    default:
      return "";
  }
}

}  // namespace

EncodeProgram make_encode_program(const PreparedPipeline& p) {
  EncodeProgram prog;
  const auto& s = p.settings;
  const auto& t = s.target;
  auto unsupported = [&](std::string why) {
    prog.supported = false;
    prog.unsupported_reason = std::move(why);
    return prog;
  };
  if (s.grade) return unsupported("grading LUTs run on the CPU");
  if (s.dither) return unsupported("dither runs on the CPU");
  if (s.ui.overlay && s.ui.srgb_blend) return unsupported("sRGB-space UI blending runs on the CPU");
  const auto tone_ptr = detail::cached_tone_stage(p);
  const detail::ToneStage& tone = *tone_ptr;
  if (tone.kind == ToneKind::reference || tone.kind == ToneKind::none)
    return unsupported(fmt::format("tone curve '{}' is an RGB operator evaluated on the CPU", p.curve_info->name));
  // A curve applied to luminance can push saturated colours out of the display gamut; the
  // CPU maps them back in ICtCp (REFERENCE.md §1.5), which this program does not do, so the
  // codes could differ by more than one.
  if (tone.kind == ToneKind::ratio && tone.ratio_of_luminance)
    return unsupported(fmt::format("tone curve '{}' applied to luminance may leave the gamut; gamut mapping runs "
                                   "on the CPU",
                                   p.curve_info->name));
  // Rec.2020 working light outside an SDR (Rec.709) container's gamut is mapped in ICtCp on
  // the CPU (encode_frame.cpp stage_container); this program only clips, which on bright
  // saturated light (a sky-lit scene's warm highlights) differs by up to ~10 codes.
  if (t.container() != color::kRec2020 && t.mode != Mode::scrgb && s.gamut == GamutMapping::ictcp)
    return unsupported("gamut mapping into the Rec.709 container (gamut ictcp) runs on the CPU; gamut clip runs here");
  // The family's other maps: this program only clips, so it runs them where nothing needs
  // mapping (a Rec.2020 container whose map keeps colours inside as they are).
  if (p.gamut_mapper && (detail::maps_every_pixel(p) || t.container() != color::kRec2020))
    return unsupported(fmt::format("gamut mapping '{}' runs on the CPU; gamut clip runs here", to_string(s.gamut)));
  const auto sig_ptr = detail::cached_signal_stage(t);
  const detail::SignalStage& sig = *sig_ptr;

  // Uniforms, printed from the prepared pipeline.
  auto& u = prog.uniforms;
  fill_mat(u.m_in, p.input_to_working * Mat3{{{{p.scene_scale, 0, 0}, {0, p.scene_scale, 0}, {0, 0, p.scene_scale}}}});
  const Mat3 to_c = detail::working_to_container(t);
  const bool container_is_working = t.container() == color::kRec2020;
  fill_mat(u.m_container, to_c);
  u.paper_white = static_cast<float>(t.paper_white_nits);
  u.peak = static_cast<float>(t.peak_nits);
  u.code_scale = sig.code_scale;
  u.code_offset = sig.code_offset;
  u.max_code = static_cast<std::uint32_t>(sig.peak_code);  // no code above the peak
  u.signal_max = sig.signal_max;
  u.hlg_peak = sig.hlg_peak;
  u.hlg_gamma = sig.hlg_gamma;
  u.gamut_lo = detail::gamut_low(t);
  auto table = [&](const char* name, const FloatBitsLut& l, float& lo, float& hi_prev, std::uint32_t& base) {
    lo = l.lo();
    hi_prev = std::nextafter(l.hi(), 0.0f);
    base = l.base_bits();
    prog.tables.push_back({name, l.table()});
  };
  if (tone.kind != ToneKind::clip) table("hdrd_tone_lut", tone.lut, u.tone_lo, u.tone_hi_prev, u.tone_base);
  u.tone_hi = tone.kind != ToneKind::clip ? tone.lut.hi() : 0.0f;
  u.tone_zero = tone.zero_nits;
  u.tone_toe_slope = tone.toe_slope;
  if (tone.has_lift) {
    table("hdrd_lift_lut", tone.lift, u.lift_lo, u.lift_hi_prev, u.lift_base);
    u.lift_zero = tone.lift_zero_nits;
    u.lift_toe_slope = tone.lift_toe_slope;
  }
  if (t.mode != Mode::scrgb) table("hdrd_signal_lut", sig.signal, u.signal_lo, u.signal_hi_prev, u.signal_base);

  // The overlay, prepared exactly as the CPU prepares it (premultiplied container nits).
  if (s.ui.overlay) {
    const auto& o = *s.ui.overlay;
    const Mat3 ui_to_c = color::rgb_to_rgb(color::kRec709, t.container());
    prog.ui.resize(o.rgba.size());
    for (std::size_t i = 0; i < o.rgba.size(); i += 4) {
      const double a = std::clamp<double>(o.rgba[i + 3], 0.0, 1.0);
      color::Vec3 enc{o.rgba[i], o.rgba[i + 1], o.rgba[i + 2]};
      if (o.premultiplied) enc = a > 0 ? enc * (1.0 / a) : color::Vec3{};
      const SdrEotf eotf = t.sdr_content_eotf;
      color::Vec3 lin{sdr_eotf(eotf, enc.x), sdr_eotf(eotf, enc.y), sdr_eotf(eotf, enc.z)};
      if (t.is_hdr() && t.sdr_inverse_tonemap != InverseTonemap::linear) {  // as the CPU's convert_overlay
        const auto m = [&](double l) {
          return sdr_light_to_nits(t.sdr_inverse_tonemap, l, t.ui_white_nits, t.peak_nits) / t.ui_white_nits;
        };
        lin = color::Vec3{m(lin.x), m(lin.y), m(lin.z)};
      }
      const color::Vec3 nits = ui_to_c * lin * (t.ui_white_nits * a);
      prog.ui[i] = static_cast<float>(nits.x);
      prog.ui[i + 1] = static_cast<float>(nits.y);
      prog.ui[i + 2] = static_cast<float>(nits.z);
      prog.ui[i + 3] = static_cast<float>(a);
    }
    prog.ui_width = o.width;
    prog.ui_height = o.height;
    u.ui_x0 = static_cast<float>(s.ui.x);
    u.ui_y0 = static_cast<float>(s.ui.y);
    u.ui_scale = static_cast<float>(s.ui.scale);
    u.ui_dim = static_cast<float>(s.ui.dim);
    u.ui_w = o.width;
    u.ui_h = o.height;
  }

  // GLSL.
  std::string g = "// Generated by hdrd (encode/kernel/gpu_program.cpp) from the CPU pipeline: do not edit.\n"
                   "precision highp float;\nprecision highp int;\nprecision highp sampler2D;\n";
  g += kernel::glsl_constants();
  g += kBlock;
  g += replace_all(replace_all(replace_all(kLut, "%SHIFT%", std::to_string(FloatBitsLut::kShift)), "%MASK%",
                               std::to_string((1u << FloatBitsLut::kShift) - 1)),
                   "%INV%", fmt::format("{:.9e}", 1.0 / (1u << FloatBitsLut::kShift)));
  if (tone.kind != ToneKind::clip)
    g += lut_function("hdrd_tone", "hdrd_tone_lut", "hdrd_u.bases.x, hdrd_u.tone_range.x, hdrd_u.tone_range.y", tone.lut);
  if (tone.has_lift)
    g += lut_function("hdrd_lift", "hdrd_lift_lut", "hdrd_u.bases.w, hdrd_u.lift_range.x, hdrd_u.lift_range.y", tone.lift);
  if (t.mode != Mode::scrgb)
    g += lut_function("hdrd_signal", "hdrd_signal_lut", "hdrd_u.bases.y, hdrd_u.tone_range.w, hdrd_u.misc.x", sig.signal);
  if (s.ui.overlay) g += std::string("uniform highp sampler2D hdrd_ui;\n") + kUi;

  g += "uvec4 hdrd_encode(vec3 rgb, ivec2 pixel) {\n"
       "  // NaN -> 0, magnitudes clamped to 1e30 (docs/encoding.md)\n"
       "  rgb = mix(clamp(rgb, vec3(-1e30), vec3(1e30)), vec3(0.0), isnan(rgb));\n"
       "  vec3 w = max(hdrd_u.m_in * rgb, vec3(0.0));\n";
  g += tone_glsl(tone, !container_is_working);
  g += container_is_working ? "  vec3 c = nits;\n" : "  vec3 c = hdrd_u.m_container * nits;\n";
  if (t.mode != Mode::scrgb) g += "  c = clamp(c, vec3(0.0), vec3(hdrd_u.levels.y));\n";
  if (s.ui.overlay) {
    g += "  vec4 ui = hdrd_ui_sample(pixel);\n"
         "  if (ui.a > 0.0) c = ui.rgb + c * ((1.0 - ui.a) * (1.0 - hdrd_u.misc.w * ui.a));\n";
    if (t.mode != Mode::scrgb) g += "  c = min(c, vec3(hdrd_u.levels.y));  // the displayable volume's cube\n";
  }
  if (t.mode == Mode::scrgb) {
    g += "  vec3 s = c * kInvScrgbUnitNits;\n"
         "  return uvec4(packHalf2x16(s.rg), packHalf2x16(vec2(s.b, 1.0)), 0u, 0u);\n}\n";
    prog.target_format = TargetFormat::rg32ui;
    prog.drm_fourcc = kDrmFormatAbgr16161616f;
    prog.glsl = std::move(g);
    return prog;
  }
  if (t.mode == Mode::hlg) {
    g += "  float yd = dot(kLuma, c);\n"
         "  float kk = yd > 0.0 ? pow(yd / hdrd_u.misc.y, (1.0 - hdrd_u.misc.z) / hdrd_u.misc.z) / hdrd_u.misc.y : 0.0;\n";
    if (s.gamut != GamutMapping::clip)
      // pipeline.cpp fit_volume: toward the grey of the same luminance, where kk is the same,
      // by the largest scale that keeps every channel's scene light at or below 1.
      g += fmt::format("  if (max(max(c.r, c.g), c.b) * kk > {}) {{\n"
                       "    vec3 d = c - vec3(yd);\n    float room = 1.0 / kk - yd, s = 1.0;\n"
                       "    if (d.r > 0.0) s = min(s, room / d.r);\n    if (d.g > 0.0) s = min(s, room / d.g);\n"
                       "    if (d.b > 0.0) s = min(s, room / d.b);\n    c = vec3(yd) + max(s, 0.0) * d;\n  }}\n",
                       glsl_float(1.0 + detail::kGamutTolerance));
    g += "  vec3 e = vec3(hdrd_signal(min(c.r * kk, 1.0)), hdrd_signal(min(c.g * kk, 1.0)), hdrd_signal(min(c.b * kk, 1.0)));\n";
  } else {
    g += "  vec3 e = vec3(hdrd_signal(c.r), hdrd_signal(c.g), hdrd_signal(c.b));\n";
  }
  g += "  e = clamp(e, vec3(0.0), vec3(1.0));\n"
       "  uvec3 code = min(uvec3(e * hdrd_u.levels.z + hdrd_u.levels.w + 0.5), uvec3(hdrd_u.bases.z));\n";
  const bool eight_bit = (t.mode == Mode::sdr || t.mode == Mode::sdr_bt1886) && t.bits == 8;
  if (eight_bit) {
    g += "  uint word = code.b | (code.g << 8) | (code.r << 16) | 0xFF000000u;\n  return uvec4(word, 0u, 0u, 0u);\n}\n";
    prog.target_format = TargetFormat::r32ui;
    prog.drm_fourcc = kDrmFormatXrgb8888;
  } else {
    g += "  uint word = code.r | (code.g << 10) | (code.b << 20) | (3u << 30);\n";
    if (s.png_samples) {
      g += t.range == Range::narrow
               ? "  uvec3 s16 = uvec3(vec3(code) * kCode10To16 + 0.5);\n"
               : "  uvec3 s16 = uvec3(min(e, vec3(hdrd_u.lift_range.z)) * kMax16 + 0.5);\n";
      g += "  return uvec4(word, s16.r | (s16.g << 16), s16.b, 0u);\n}\n";
      prog.target_format = TargetFormat::rgba32ui;
    } else {
      g += "  return uvec4(word, 0u, 0u, 0u);\n}\n";
      prog.target_format = TargetFormat::r32ui;
    }
    prog.drm_fourcc = kDrmFormatXbgr2101010;
  }
  prog.glsl = std::move(g);
  return prog;
}

Result<EncodedFrame> frame_from_readback(const PreparedPipeline& p, const EncodeProgram& prog, int width,
                                         int height, const void* pixels, bool bottom_up) {
  if (!prog.supported) return make_error("gpu.unsupported", prog.unsupported_reason);
  if (auto ok = check_image_size(width, height); !ok) return ok.error();
  EncodedFrame f;
  f.target = p.settings.target;
  f.width = width;
  f.height = height;
  f.drm_fourcc = prog.drm_fourcc;
  const std::size_t in_px = prog.target_format == TargetFormat::r32ui ? 4 : (prog.target_format == TargetFormat::rg32ui ? 8 : 16);
  const std::size_t out_px = prog.target_format == TargetFormat::rg32ui ? 8 : 4;
  f.stride_bytes = out_px * static_cast<std::size_t>(width);
  f.data.resize(f.stride_bytes * static_cast<std::size_t>(height));
  if (prog.target_format == TargetFormat::rgba32ui) f.signal16.resize(static_cast<std::size_t>(width) * height * 3);
  const auto* src = static_cast<const std::uint8_t*>(pixels);
  for (int y = 0; y < height; ++y) {
    const int sy = bottom_up ? height - 1 - y : y;
    const std::uint8_t* row = src + static_cast<std::size_t>(sy) * width * in_px;
    std::uint8_t* dst = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    if (prog.target_format != TargetFormat::rgba32ui) {
      std::memcpy(dst, row, f.stride_bytes);
      continue;
    }
    for (int x = 0; x < width; ++x) {
      std::uint32_t v[4];
      std::memcpy(v, row + static_cast<std::size_t>(x) * 16, 16);
      std::memcpy(dst + static_cast<std::size_t>(x) * 4, &v[0], 4);
      std::uint16_t* s16 = f.signal16.data() + (static_cast<std::size_t>(y) * width + x) * 3;
      s16[0] = static_cast<std::uint16_t>(v[1] & 0xFFFF);
      s16[1] = static_cast<std::uint16_t>(v[1] >> 16);
      s16[2] = static_cast<std::uint16_t>(v[2] & 0xFFFF);
    }
  }
  f.mastering = f.target.mastering();
  f.content_light = measure_content_light(f);
  f.settings = p.describe();
  f.settings["encoder"] = "gpu";
  return f;
}

}  // namespace hdrd::gpu

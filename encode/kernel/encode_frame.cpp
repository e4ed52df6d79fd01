// Frame encoding: the staged row pipeline (input -> tone -> container/gamut -> UI ->
// signal -> pack), run over row bands on worker threads. Tables come from the reference
// functions (pipeline_internal.hpp), so this path and the reference agree to a code.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "encode/kernel/fast_fused.hpp"
#include "encode/kernel/fast_kernels.hpp"
#include "encode/kernel/float_lut.hpp"
#include "encode/pipeline.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/parallel.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd {

using color::Mat3;
using color::Vec3;
using detail::SignalStage;
using detail::ToneKind;
using detail::ToneStage;

namespace {

struct Mat3f {
  float m[9];
  explicit Mat3f(const Mat3& a) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[i * 3 + j] = static_cast<float>(a.m[i][j]);
  }
};

// The UI overlay converted for blending: premultiplied linear container nits + alpha, or
// (for sRGB-space blending) straight sRGB-encoded values + alpha. The conversion is kept
// for the next frame (a real-time loop composites the same overlay every frame).
struct ConvertedUi {
  std::vector<float> px;
  float max_light = 0;  // the largest premultiplied channel (linear blending), nits
};

struct PreparedUi {
  std::shared_ptr<const ConvertedUi> pixels;
  const float* px = nullptr;  // pixels->px.data()
  int w = 0, h = 0, x0 = 0, y0 = 0;
  float scale = 1, dim = 0, white = 203;
  bool srgb_blend = false;
  SdrEotf eotf = SdrEotf::srgb;  // DisplayTarget::sdr_content_eotf: how the UI decodes to light
  bool active() const { return w > 0; }
};

// The SDR content EOTF from a table (UI values are mostly 8-bit levels; 1e-8 off the
// function), one per EOTF, built once; sRGB's toe join (0.04045) is a node.
const FloatBitsLut& sdr_eotf_table(SdrEotf e) {
  auto make = [](SdrEotf which) {
    const double kinks[] = {0.04045};
    return FloatBitsLut([which](double v) { return sdr_eotf(which, v); }, -24, 1,
                        which == SdrEotf::srgb ? std::span<const double>(kinks) : std::span<const double>());
  };
  static const FloatBitsLut tables[] = {make(SdrEotf::srgb), make(SdrEotf::gamma22), make(SdrEotf::bt1886)};
  return tables[static_cast<int>(e)];
}

ConvertedUi convert_overlay(const OverlayImage& o, const color::Primaries& container, double ui_white,
                           bool srgb_blend, SdrEotf eotf, InverseTonemap itm, double peak) {
  const Mat3f to_c(color::rgb_to_rgb(color::kRec709, container));
  const FloatBitsLut& decode = sdr_eotf_table(eotf);
  std::vector<float> px(o.rgba.size());
  float max_light = 0;
  const std::size_t n = static_cast<std::size_t>(o.width) * o.height;
  for (std::size_t i = 0; i < n; ++i) {
    const float* q = &o.rgba[i * 4];
    const float a = std::clamp(q[3], 0.0f, 1.0f);
    float enc[3] = {q[0], q[1], q[2]};
    if (o.premultiplied)
      for (float& c : enc) c = a > 0 ? c / a : 0.0f;
    float* out = &px[i * 4];
    if (srgb_blend) {
      std::copy_n(enc, 3, out);
    } else {
      float lin[3];
      for (int c = 0; c < 3; ++c) lin[c] = enc[c] > 0 ? decode(enc[c]) : 0.0f;
      if (itm != InverseTonemap::linear) {
        // Per channel in the UI's own Rec.709 light, then the container matrix (linear keeps
        // today's float path bit for bit).
        for (float& l : lin) l = static_cast<float>(sdr_light_to_nits(itm, l, ui_white, peak) / ui_white);
      }
      const float k = static_cast<float>(ui_white) * a;
      for (int c = 0; c < 3; ++c) {
        out[c] = (to_c.m[c * 3] * lin[0] + to_c.m[c * 3 + 1] * lin[1] + to_c.m[c * 3 + 2] * lin[2]) * k;
        // NaN (from a NaN alpha) counts as unbounded: the kernel then keeps its clamps.
        max_light = std::isnan(out[c]) ? std::numeric_limits<float>::infinity() : std::max(max_light, out[c]);
      }
    }
    out[3] = a;
  }
  return {std::move(px), max_light};
}

std::shared_ptr<const ConvertedUi> converted_overlay(const std::shared_ptr<const OverlayImage>& o,
                                                     const color::Primaries& container, double ui_white,
                                                     bool srgb_blend, SdrEotf eotf, InverseTonemap itm,
                                                     double peak) {
  struct Entry {
    std::weak_ptr<const OverlayImage> overlay;
    color::Primaries container;
    double ui_white;
    bool srgb_blend;
    SdrEotf eotf;
    InverseTonemap itm;
    double peak;
    std::shared_ptr<const ConvertedUi> pixels;
  };
  static std::mutex mu;
  static std::optional<Entry> last;
  {
    std::lock_guard lock(mu);
    if (last && last->overlay.lock() == o && last->container == container && last->ui_white == ui_white &&
        last->srgb_blend == srgb_blend && last->eotf == eotf && last->itm == itm && last->peak == peak)
      return last->pixels;
  }
  auto px = std::make_shared<const ConvertedUi>(convert_overlay(*o, container, ui_white, srgb_blend, eotf, itm, peak));
  std::lock_guard lock(mu);
  last = Entry{o, container, ui_white, srgb_blend, eotf, itm, peak, px};
  return px;
}

PreparedUi prepare_ui(const PreparedPipeline& p) {
  PreparedUi ui;
  const auto& s = p.settings.ui;
  if (!s.overlay) return ui;
  ui.w = s.overlay->width;
  ui.h = s.overlay->height;
  ui.x0 = s.x;
  ui.y0 = s.y;
  ui.scale = static_cast<float>(s.scale);
  ui.dim = static_cast<float>(s.dim);
  ui.white = static_cast<float>(p.settings.target.ui_white_nits);
  ui.srgb_blend = s.srgb_blend;
  ui.eotf = p.settings.target.sdr_content_eotf;
  // Inverse tone mapping only into HDR frames; in SDR modes UI white is the display's white.
  const InverseTonemap itm =
      p.settings.target.is_hdr() ? p.settings.target.sdr_inverse_tonemap : InverseTonemap::linear;
  ui.pixels = converted_overlay(s.overlay, p.settings.target.container(), p.settings.target.ui_white_nits, s.srgb_blend,
                                ui.eotf, itm, p.settings.target.peak_nits);
  ui.px = ui.pixels->px.data();
  return ui;
}

// Bilinear sample of the prepared overlay at output pixel centre (x, y); alpha 0 outside.
std::array<float, 4> sample_ui(const PreparedUi& ui, int x, int y) {
  const float u = (x + 0.5f - ui.x0) / ui.scale - 0.5f;
  const float v = (y + 0.5f - ui.y0) / ui.scale - 0.5f;
  if (u < -0.5f || v < -0.5f || u > ui.w - 0.5f || v > ui.h - 0.5f) return {0, 0, 0, 0};
  const float fu = std::floor(u), fv = std::floor(v);
  const float tu = u - fu, tv = v - fv;
  std::array<float, 4> out{};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const int sx = std::clamp(static_cast<int>(fu) + i, 0, ui.w - 1);
      const int sy = std::clamp(static_cast<int>(fv) + j, 0, ui.h - 1);
      const float wgt = (i ? tu : 1 - tu) * (j ? tv : 1 - tv);
      const float* q = &ui.px[(static_cast<std::size_t>(sy) * ui.w + sx) * 4];
      for (int c = 0; c < 4; ++c) out[c] += wgt * q[c];
    }
  return out;
}

// REFERENCE.md §1.6: blend UI sample s over one display-referred pixel in linear light
// (or in the UI's own encoding relative to UI white, for UIs authored that way: sRGB, or
// the SDR content EOTF the target names).
void composite_ui_pixel(const PreparedUi& ui, const std::array<float, 4>& s, float* px) {
  const float a = s[3];
  if (a <= 0) return;
  const float keep = (1 - a) * (1 - ui.dim * a);
  if (!ui.srgb_blend) {
    for (int c = 0; c < 3; ++c) px[c] = s[c] + px[c] * keep;
    return;
  }
  // s holds alpha-weighted encoded values (bilinear of straight values would bleed).
  for (int c = 0; c < 3; ++c) {
    const double bg = sdr_inverse_eotf(ui.eotf, std::clamp(px[c] * (1 - ui.dim * a) / ui.white, 0.0f, 1.0f));
    const double enc = s[c] + bg * (1 - a);
    px[c] = static_cast<float>(sdr_eotf(ui.eotf, enc) * ui.white);
  }
}

void composite_ui_row(const PreparedUi& ui, int y, int width, float* row) {
  if (y + 0.5f < ui.y0 - ui.scale || y + 0.5f > ui.y0 + (ui.h + 0.5f) * ui.scale) return;
  const int x_begin = std::max(0, static_cast<int>(std::floor(ui.x0 - ui.scale)));
  const int x_end = std::min(width, static_cast<int>(std::ceil(ui.x0 + (ui.w + 1) * ui.scale)));
  for (int x = x_begin; x < x_end; ++x) composite_ui_pixel(ui, sample_ui(ui, x, y), row + static_cast<std::size_t>(x) * 4);
}

// The linear-light UI of row y over columns [x0, x0 + n) for the fused kernel: premultiplied
// container nits and what is kept of the frame below, (1 - a)(1 - dim a), per pixel.
void ui_row_for_kernel(const PreparedUi& ui, int y, int x0, int n, std::vector<float>& out) {
  out.resize(static_cast<std::size_t>(n) * 4);
  auto put = [dim = ui.dim](const float* s, float* o) {
    const float a = std::max(s[3], 0.0f);
    o[0] = a > 0 ? s[0] : 0, o[1] = a > 0 ? s[1] : 0, o[2] = a > 0 ? s[2] : 0;
    o[3] = (1 - a) * (1 - dim * a);
  };
  if (ui.scale != 1.0f) {
    for (int i = 0; i < n; ++i) {
      const auto s = sample_ui(ui, x0 + i, y);
      put(s.data(), &out[static_cast<std::size_t>(i) * 4]);
    }
    return;
  }
  // Unscaled: the overlay row itself between [i0, i1), nothing (keep everything) around it;
  // a branch-free loop per part, which the compiler vectorises.
  const int sy = y - ui.y0;
  const bool row_inside = sy >= 0 && sy < ui.h;
  const int i0 = row_inside ? std::clamp(ui.x0 - x0, 0, n) : n;
  const int i1 = row_inside ? std::clamp(ui.x0 + ui.w - x0, i0, n) : n;
  constexpr float kNothing[4] = {0, 0, 0, 0};
  for (int i = 0; i < i0; ++i) put(kNothing, &out[static_cast<std::size_t>(i) * 4]);
  const float* src = row_inside ? &ui.px[(static_cast<std::size_t>(sy) * ui.w + (x0 + i0 - ui.x0)) * 4] : nullptr;
  for (int i = i0; i < i1; ++i) put(src + static_cast<std::size_t>(i - i0) * 4, &out[static_cast<std::size_t>(i) * 4]);
  for (int i = i1; i < n; ++i) put(kNothing, &out[static_cast<std::size_t>(i) * 4]);
}

constexpr float kBayer8[64] = {
    0, 32, 8, 40, 2, 34, 10, 42, 48, 16, 56, 24, 50, 18, 58, 26, 12, 44, 4, 36, 14, 46, 6, 38,
    60, 28, 52, 20, 62, 30, 54, 22, 3, 35, 11, 43, 1, 33, 9, 41, 51, 19, 59, 27, 49, 17, 57, 25,
    15, 47, 7, 39, 13, 45, 5, 37, 63, 31, 55, 23, 61, 29, 53, 21};

struct ContentLightAccumulator {
  double max_nits = 0;
  double sum_nits = 0;
};

struct FrameJob {
  const SceneInput* in;
  const PreparedPipeline* p;
  const ToneStage* tone;
  const SignalStage* sig;
  const PreparedUi* ui;
  Mat3f m_in{Mat3::identity()};
  Mat3f to_c{Mat3::identity()};
  bool container_is_working = true;
  EncodedFrame* frame = nullptr;
  int width = 0;
  std::optional<kernels::FusedRow> fused = std::nullopt;  // the fused SIMD kernel's template, when eligible
  bool fused_ui = false;                   // ... and it composites the UI too (linear blending, not scRGB)
};

void stage_input(const FrameJob& job, int y, int x0, int n, float* row) {
  const std::size_t base = static_cast<std::size_t>(y) * job.width + x0;
  if (job.in->half)
    kernels::half_rows_to_working(job.in->half->rgba.data() + base * 4, n, job.m_in.m, row);
  else
    kernels::float_rows_to_working(job.in->image->rgba.data() + base * 4, n, job.m_in.m, row);
}

void stage_tone(const FrameJob& job, int n, float* row) {
  const ToneStage& t = *job.tone;
  switch (t.kind) {
    case ToneKind::clip:
      kernels::tone_clip(row, n, t.paper_white, t.peak);
      break;
    case ToneKind::per_channel:
      for (int i = 0; i < n * 4; i += 4)
        for (int c = 0; c < 3; ++c) row[i + c] = detail::toe_lookup(t.lut, t.zero_nits, t.toe_slope, row[i + c]);
      break;
    case ToneKind::ratio:
      kernels::tone_ratio(row, n, t.lut, t.ratio_of_luminance, job.container_is_working ? nullptr : job.to_c.m);
      if (t.has_lift)
        for (int i = 0; i < n * 4; i += 4)
          for (int c = 0; c < 3; ++c)
            row[i + c] = detail::toe_lookup(t.lift, t.lift_zero_nits, t.lift_toe_slope, row[i + c]);
      break;
    case ToneKind::reference: {
      const auto& p = *job.p;
      for (int i = 0; i < n * 4; i += 4) {
        const Vec3 nits = p.curve->map_rgb({row[i], row[i + 1], row[i + 2]}, p.apply) * p.settings.target.paper_white_nits;
        row[i] = static_cast<float>(nits.x);
        row[i + 1] = static_cast<float>(nits.y);
        row[i + 2] = static_cast<float>(nits.z);
      }
      break;
    }
    case ToneKind::none:
      break;
  }
}

// Working nits -> container nits, gamut-mapping what does not fit (rare: only those
// pixels take the ICtCp reference path).
void stage_container(const FrameJob& job, int n, float* row) {
  const auto& t = job.p->settings.target;
  const float lo = detail::gamut_low(t), peak = detail::gamut_high(t);
  const bool map = t.mode != Mode::scrgb;
  const gamut::Mapper* mapper = job.p->gamut_mapper.get();
  const bool every = detail::maps_every_pixel(*job.p);
  for (int i = 0; i < n * 4; i += 4) {
    float r = row[i], g = row[i + 1], b = row[i + 2];
    if (!job.container_is_working) {
      const float* m = job.to_c.m;
      const float cr = m[0] * r + m[1] * g + m[2] * b;
      const float cg = m[3] * r + m[4] * g + m[5] * b;
      const float cb = m[6] * r + m[7] * g + m[8] * b;
      r = cr, g = cg, b = cb;
    }
    if (map && (every || !(r >= lo && g >= lo && b >= lo && r <= peak && g <= peak && b <= peak))) {
      const Vec3 c = detail::gamut_map({row[i], row[i + 1], row[i + 2]}, t, job.p->settings.gamut, mapper);
      r = static_cast<float>(c.x), g = static_cast<float>(c.y), b = static_cast<float>(c.z);
    }
    row[i] = r, row[i + 1] = g, row[i + 2] = b;
  }
}

// Container light after the UI -> inside the mode's displayable volume, in place (the
// dump is written after this): the cube clamp, the HLG volume (fit_volume, taken only by
// the pixels whose scene light would pass 1) and, when the dump is kept, the black floors.
// Returns the HLG scene-light scale k (0 for the other modes) for the encoder.
float to_volume(const FrameJob& job, const SignalStage& s, float* px) {
  const auto& t = job.p->settings.target;
  const float peak = static_cast<float>(t.peak_nits);
  for (int c = 0; c < 3; ++c) px[c] = std::clamp(px[c], 0.0f, peak);
  float k = 0;
  auto scale = [&] {
    const float yd = kernel::rec2020_luminance(px[0], px[1], px[2]);
    return yd > 0 ? std::pow(yd / s.hlg_peak, (1 - s.hlg_gamma) / s.hlg_gamma) / s.hlg_peak : 0.0f;
  };
  auto put = [&](Vec3 v) {
    px[0] = static_cast<float>(v.x), px[1] = static_cast<float>(v.y), px[2] = static_cast<float>(v.z);
  };
  if (s.mode == Mode::hlg) {
    k = scale();
    if (std::max({px[0], px[1], px[2]}) * k > 1 + detail::kGamutTolerance) {
      put(detail::fit_volume({px[0], px[1], px[2]}, t, job.p->settings.gamut));
      k = scale();
    }
  }
  if (job.frame->display_nits && detail::has_black_floor(t)) {
    put(detail::displayed_light({px[0], px[1], px[2]}, t));
    if (s.mode == Mode::hlg) k = scale();
  }
  return k;
}

void stage_encode(const FrameJob& job, int y, int x0, int n, float* row, ContentLightAccumulator& cll) {
  EncodedFrame& f = *job.frame;
  const SignalStage& s = *job.sig;
  const bool dither = job.p->settings.dither;
  const float* bayer_row = kBayer8 + (y & 7) * 8;
  const std::size_t bpp = f.drm_fourcc == kDrmFormatAbgr16161616f ? 8 : 4;
  std::uint8_t* out = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + x0 * bpp;
  std::uint16_t* s16 = f.signal16.empty()
                           ? nullptr
                           : f.signal16.data() + (static_cast<std::size_t>(y) * job.width + x0) * 3;
  const bool narrow = s.code_offset != 0;

  if (s.mode == Mode::scrgb) {
    auto* o = reinterpret_cast<std::uint16_t*>(out);
    const Mat3f to2020(color::rgb_to_rgb(color::kRec709, color::kRec2020));
    for (int x = 0; x < n; ++x) {
      const float* px = row + x * 4;
      for (int c = 0; c < 3; ++c) o[x * 4 + c] = detail::float_to_half(px[c] * kernel::kInvScrgbUnitNits);
      o[x * 4 + 3] = 0x3C00;  // alpha 1.0
      // MaxCLL of the Rec.2020 signal the scRGB frame would be sent as (REFERENCE.md §6).
      const float* m = to2020.m;
      const float r = detail::half_to_float(o[x * 4]) * kernel::kScrgbUnitNits,
                  g = detail::half_to_float(o[x * 4 + 1]) * kernel::kScrgbUnitNits,
                  b = detail::half_to_float(o[x * 4 + 2]) * kernel::kScrgbUnitNits;
      const float mx = std::max({m[0] * r + m[1] * g + m[2] * b, m[3] * r + m[4] * g + m[5] * b,
                                 m[6] * r + m[7] * g + m[8] * b, 0.0f});
      cll.max_nits = std::max<double>(cll.max_nits, mx);
      cll.sum_nits += mx;
    }
    return;
  }

  std::array<float, 3> e;
  for (int x = 0; x < n; ++x) {
    float* px = row + x * 4;
    const float k = to_volume(job, s, px);
    if (s.mode == Mode::hlg) {
      // BT.2100 inverse OOTF (a scale of the luminance alone), then the OETF per channel
      // with the black lift (the signal table).
      e = {s.signal(std::min(px[0] * k, 1.0f)), s.signal(std::min(px[1] * k, 1.0f)), s.signal(std::min(px[2] * k, 1.0f))};
    } else {
      e = {s.signal(px[0]), s.signal(px[1]), s.signal(px[2])};
    }
    const float bias = dither ? bayer_row[(x0 + x) & 7] * (1.0f / 64.0f) + (0.5f / 64.0f) : 0.5f;
    int code[3];
    for (int c = 0; c < 3; ++c) {
      const float v = std::clamp(e[c], 0.0f, s.signal_max);
      code[c] = std::clamp(static_cast<int>(v * s.code_scale + s.code_offset + bias), 0, s.peak_code);
      if (s16) {
        const float v16 = narrow ? code[c] * kernel::kCode10To16 : v * kernel::kMax16;
        s16[x * 3 + c] = static_cast<std::uint16_t>(std::lround(v16));
      }
    }
    if (f.drm_fourcc == kDrmFormatXrgb8888) {
      out[x * 4 + 0] = static_cast<std::uint8_t>(code[2]);
      out[x * 4 + 1] = static_cast<std::uint8_t>(code[1]);
      out[x * 4 + 2] = static_cast<std::uint8_t>(code[0]);
      out[x * 4 + 3] = 0xFF;
    } else {
      const std::uint32_t w = static_cast<std::uint32_t>(code[0]) | (static_cast<std::uint32_t>(code[1]) << 10) |
                              (static_cast<std::uint32_t>(code[2]) << 20) | (3u << 30);
      std::memcpy(out + x * 4, &w, 4);
    }
    if (s.mode == Mode::hdr10) {
      const float mx = s.code_to_nits[static_cast<std::size_t>(std::max({code[0], code[1], code[2]}))];
      cll.max_nits = std::max<double>(cll.max_nits, mx);
      cll.sum_nits += mx;
    } else if (s.mode == Mode::hlg) {
      const float er = s.code_to_nits[code[0]], eg = s.code_to_nits[code[1]], eb = s.code_to_nits[code[2]];
      const float mx = detail::hlg_ootf_gain(s, er, eg, eb) * std::max({er, eg, eb});
      cll.max_nits = std::max<double>(cll.max_nits, mx);
      cll.sum_nits += mx;
    }
  }
}

// The staged path over pixels [x0, x0 + n) of row y (no UI: callers handle it).
void run_staged(const FrameJob& job, int y, int x0, int n, float* row) {
  const auto* g = job.p->settings.grade.get();
  const auto placement = g ? g->placement() : grade::Placement::display;
  stage_input(job, y, x0, n, row);
  if (g && placement != grade::Placement::display) g->apply(row, static_cast<std::size_t>(n));
  stage_tone(job, n, row);
  if (g && placement == grade::Placement::display) g->apply(row, static_cast<std::size_t>(n));
  stage_container(job, n, row);
}

bool ui_touches_row(const PreparedUi& ui, int y) {
  return ui.active() && y + 1 > ui.y0 - ui.scale && y < ui.y0 + (ui.h + 1) * ui.scale;
}

// The display light of pixels [x, x + n) of row y for the EXR dump, when the frame keeps
// it: `row` after stage_encode (which moved it into the displayable volume).
void keep_display_light(const FrameJob& job, int y, int x, int n, const float* row) {
  if (job.frame->display_nits)
    std::memcpy(job.frame->display_nits->px(x, y), row, static_cast<std::size_t>(n) * 4 * sizeof(float));
}

// The staged path for single pixels of a fused row (its tail, out-of-gamut pixels), with
// the UI composited when the row had one.
void run_staged_pixels(const FrameJob& job, int y, int x, int n, const PreparedUi* ui, float* row,
                       ContentLightAccumulator& cll) {
  run_staged(job, y, x, n, row);
  if (ui)
    for (int i = 0; i < n; ++i) composite_ui_pixel(*ui, sample_ui(*ui, x + i, y), row + static_cast<std::size_t>(i) * 4);
  stage_encode(job, y, x, n, row, cll);
  keep_display_light(job, y, x, n, row);
}

// The fused kernel over pixels [x0, x0 + n) of row y, compositing ui_row (from
// ui_row_for_kernel) when given; its tail and out-of-gamut pixels take the exact path.
void run_fused(const FrameJob& job, int y, int x0, int n, std::vector<float>& row, std::vector<int>& fallback,
               ContentLightAccumulator& cll, const float* ui_row = nullptr) {
  if (n <= 0) return;
  kernels::FusedRow fr = *job.fused;
  const std::size_t base = static_cast<std::size_t>(y) * job.width + x0;
  if (job.in->half) fr.half_in = job.in->half->rgba.data() + base * 4;
  else fr.float_in = job.in->image->rgba.data() + base * 4;
  fr.n = n;
  const std::size_t bpp = job.frame->drm_fourcc == kDrmFormatAbgr16161616f ? 8 : 4;
  fr.out = job.frame->data.data() + static_cast<std::size_t>(y) * job.frame->stride_bytes + x0 * bpp;
  fr.signal16 = job.frame->signal16.empty() ? nullptr : job.frame->signal16.data() + base * 3;
  fr.fallback = fallback.data();
  fr.display = job.frame->display_nits ? job.frame->display_nits->px(x0, y) : nullptr;
  fr.ui = ui_row;
  fr.ui_max = ui_row ? job.ui->pixels->max_light : 0.0f;
  kernels::fused_row(fr);
  cll.max_nits = std::max(cll.max_nits, fr.max_nits);
  cll.sum_nits += fr.sum_nits;
  const PreparedUi* ui = ui_row ? job.ui : nullptr;
  if (fr.done < n) run_staged_pixels(job, y, x0 + fr.done, n - fr.done, ui, row.data(), cll);
  for (int i = 0; i < fr.fallback_count; ++i) run_staged_pixels(job, y, x0 + fallback[i], 1, ui, row.data(), cll);
}

// The columns the UI can touch, [begin, end), widened to multiples of kUiColumnAlign so
// that the three kernel calls of a UI row leave no tails for the exact (scalar) path but the
// row's own (with a 1200-pixel UI at x = 100 the unaligned split sent 16 pixels of every UI
// row there). Columns the overlay does not cover composite nothing (alpha 0).
constexpr int kUiColumnAlign = 16;  // a multiple of every target's lane count
std::pair<int, int> ui_columns(const PreparedUi& ui, int width) {
  int begin = std::clamp(static_cast<int>(std::floor(ui.x0 - ui.scale)), 0, width);
  int end = std::clamp(static_cast<int>(std::ceil(ui.x0 + (ui.w + 1) * ui.scale)), begin, width);
  begin -= begin % kUiColumnAlign;
  end = std::min(width, end + (kUiColumnAlign - end % kUiColumnAlign) % kUiColumnAlign);
  return {begin, end};
}

// One worker's buffers, reused over its bands.
struct RowScratch {
  explicit RowScratch(int w) : row(static_cast<std::size_t>(w) * 4), fallback(static_cast<std::size_t>(w)) {}
  std::vector<float> row;
  std::vector<int> fallback;
  std::vector<float> ui_row;
};

void run_rows(const FrameJob& job, int y_begin, int y_end, ContentLightAccumulator& cll, RowScratch& scratch) {
  const int w = job.width;
  auto& [row, fallback, ui_row] = scratch;
  for (int y = y_begin; y < y_end; ++y) {
    if (job.fused && !ui_touches_row(*job.ui, y)) {
      run_fused(job, y, 0, w, row, fallback, cll);
      continue;
    }
    if (job.fused) {
      // Only the columns under the UI need it.
      const auto [x0, x1] = ui_columns(*job.ui, w);
      run_fused(job, y, 0, x0, row, fallback, cll);
      run_fused(job, y, x1, w - x1, row, fallback, cll);
      if (x1 > x0 && job.fused_ui) {
        ui_row_for_kernel(*job.ui, y, x0, x1 - x0, ui_row);
        run_fused(job, y, x0, x1 - x0, row, fallback, cll, ui_row.data());
      } else if (x1 > x0) {
        float* ui_px = row.data() + static_cast<std::size_t>(x0) * 4;
        run_staged(job, y, x0, x1 - x0, ui_px);
        composite_ui_row(*job.ui, y, w, row.data());
        stage_encode(job, y, x0, x1 - x0, ui_px, cll);
        keep_display_light(job, y, x0, x1 - x0, ui_px);
      }
      continue;
    }
    run_staged(job, y, 0, w, row.data());
    if (job.ui->active()) composite_ui_row(*job.ui, y, w, row.data());
    stage_encode(job, y, 0, w, row.data(), cll);  // moves the light into the displayable volume first
    keep_display_light(job, y, 0, w, row.data());
  }
}

// The fused kernel's parameters, when this frame can use it.
std::optional<kernels::FusedRow> fused_template(const FrameJob& job) {
  const auto& p = *job.p;
  const auto& t = p.settings.target;
  if (p.settings.grade || p.settings.dither || p.settings.staged_only || detail::maps_every_pixel(p)) return std::nullopt;
  if (t.mode == Mode::hlg) return std::nullopt;
  kernels::FusedRow r;
  switch (job.tone->kind) {
    case ToneKind::clip: r.tone = kernels::FusedTone::clip; break;
    case ToneKind::per_channel: r.tone = kernels::FusedTone::per_channel; break;
    case ToneKind::ratio:
      r.tone = job.tone->ratio_of_luminance ? kernels::FusedTone::ratio_luminance : kernels::FusedTone::ratio_max;
      break;
    default: return std::nullopt;
  }
  auto view = [](const FloatBitsLut& l) {
    return kernels::LutView{l.table().data(),  l.pairs().data(), l.base_bits(),
                            l.lo(),            l.hi(),           std::nextafter(l.hi(), 0.0f),
                            l.flat_below(),    l.patches().data(), static_cast<int>(l.patches().size())};
  };
  r.m_in = job.m_in.m;
  r.paper_white = job.tone->paper_white;
  r.peak = job.tone->peak;
  if (job.tone->kind != ToneKind::clip) r.tone_lut = view(job.tone->lut);
  r.tone_zero = job.tone->zero_nits;
  r.tone_toe_slope = job.tone->toe_slope;
  if (job.tone->has_lift) {
    r.lift = view(job.tone->lift);
    r.lift_zero = job.tone->lift_zero_nits;
    r.lift_toe_slope = job.tone->lift_toe_slope;
  }
  r.m_container = job.container_is_working ? nullptr : job.to_c.m;
  // The display light the dump keeps: to_volume's cube clamp and black floor (HLG, whose
  // volume is not a cube, never comes here).
  r.display_hi = static_cast<float>(t.peak_nits);
  r.display_lo = detail::has_black_floor(t) ? static_cast<float>(t.black_nits) : 0.0f;
  if (t.mode == Mode::scrgb) {
    r.out_kind = kernels::FusedOut::scrgb;
    r.gamut_lo = -std::numeric_limits<float>::infinity();
    r.gamut_hi = std::numeric_limits<float>::infinity();
    return r;
  }
  r.gamut_lo = detail::gamut_low(t);
  r.gamut_hi = detail::gamut_high(t);
  // Clip and the ratio of max(RGB) keep every channel in [0, peak] by construction (the
  // curves never exceed the peak: tonemap_test); only a container matrix can leave it.
  r.gamut_check = !(job.container_is_working && (r.tone == kernels::FusedTone::clip ||
                                                 r.tone == kernels::FusedTone::ratio_max));
  r.out_kind = job.frame->drm_fourcc == kDrmFormatXrgb8888 ? kernels::FusedOut::xrgb8 : kernels::FusedOut::packed10;
  r.signal = view(job.sig->signal);
  if (!job.sig->codes.empty())
    r.codes = {job.sig->codes.table().data(), job.sig->codes.base_bits(), job.sig->codes.top_rel(),
               job.sig->codes.shift()};
  r.code_scale = job.sig->code_scale;
  r.code_offset = job.sig->code_offset;
  r.max_code = job.sig->peak_code;
  r.signal_max = job.sig->signal_max;
  r.narrow = job.sig->code_offset != 0;
  r.code_to_nits = t.mode == Mode::hdr10 ? job.sig->code_to_nits.data() : nullptr;
  if (r.code_to_nits && !job.sig->code_nits_poly.empty()) r.code_nits_poly = job.sig->code_nits_poly.data();
  return r;
}

void setup_frame(EncodedFrame& f, const DisplayTarget& t, int w, int h, bool keep_nits, bool png_samples) {
  f.target = t;
  f.width = w;
  f.height = h;
  const bool eight_bit_sdr = (t.mode == Mode::sdr || t.mode == Mode::sdr_bt1886) && t.bits == 8;
  if (t.mode == Mode::scrgb) {
    f.drm_fourcc = kDrmFormatAbgr16161616f;
    f.stride_bytes = static_cast<std::size_t>(w) * 8;
  } else if (eight_bit_sdr) {
    f.drm_fourcc = kDrmFormatXrgb8888;
    f.stride_bytes = static_cast<std::size_t>(w) * 4;
  } else {
    f.drm_fourcc = kDrmFormatXbgr2101010;
    f.stride_bytes = static_cast<std::size_t>(w) * 4;
    if (png_samples) f.signal16.resize(static_cast<std::size_t>(w) * h * 3);
  }
  if (!png_samples || f.drm_fourcc != kDrmFormatXbgr2101010) f.signal16.clear();
  f.data.resize(f.stride_bytes * h);
  if (keep_nits && (!f.display_nits || f.display_nits->width != w || f.display_nits->height != h))
    f.display_nits.emplace(w, h);
  if (!keep_nits) f.display_nits.reset();
  if (f.display_nits)
    for (std::size_t i = 3; i < f.display_nits->rgba.size(); i += 4) f.display_nits->rgba[i] = 1.0f;
  f.mastering = t.mastering();
}

}  // namespace

Result<void> encode_prepared_into(const SceneInput& in, const PreparedPipeline& p, EncodedFrame& frame) {
  const auto& t = p.settings.target;
  const int w = in.image ? in.image->width : in.half->width;
  const int h = in.image ? in.image->height : in.half->height;
  const auto tone_ptr = detail::cached_tone_stage(p);
  const auto sig_ptr = detail::cached_signal_stage(t);
  const ToneStage& tone = *tone_ptr;
  const SignalStage& sig = *sig_ptr;
  const PreparedUi ui = prepare_ui(p);

  setup_frame(frame, t, w, h, p.settings.keep_display_nits, p.settings.png_samples);
  FrameJob job{&in, &p, &tone, &sig, &ui};
  job.m_in = Mat3f(p.input_to_working * Mat3{{{{p.scene_scale, 0, 0}, {0, p.scene_scale, 0}, {0, 0, p.scene_scale}}}});
  job.to_c = Mat3f(detail::working_to_container(t));
  job.container_is_working = t.container() == color::kRec2020;
  job.frame = &frame;
  job.width = w;
  job.fused = fused_template(job);
  job.fused_ui = job.fused && ui.active() && !ui.srgb_blend && job.fused->out_kind != kernels::FusedOut::scrgb;

  const int threads = std::clamp(p.settings.threads > 0 ? p.settings.threads : hardware_threads(), 1, std::max(1, h));
  std::vector<ContentLightAccumulator> cll(static_cast<std::size_t>(threads));
  // Bands of rows handed out dynamically so a slow band (gamut mapping, UI) doesn't stall
  // others; the calling thread is one of the workers (the shared pool, encode/parallel.hpp).
  constexpr int kBand = 16;
  std::atomic<int> next{0};
  auto worker = [&](int i) {
    RowScratch scratch(w);
    for (int y0 = next.fetch_add(kBand); y0 < h; y0 = next.fetch_add(kBand))
      run_rows(job, y0, std::min(h, y0 + kBand), cll[static_cast<std::size_t>(i)], scratch);
  };
  parallel_run(threads, worker);
  double max_nits = 0, sum = 0;
  for (const auto& c : cll) {
    max_nits = std::max(max_nits, c.max_nits);
    sum += c.sum_nits;
  }
  frame.content_light = {max_nits, sum / (static_cast<double>(w) * h)};
  frame.settings = p.describe();
  return {};
}

Result<EncodedFrame> encode_prepared(const SceneInput& in, const PreparedPipeline& p) {
  EncodedFrame frame;
  if (auto ok = encode_prepared_into(in, p, frame); !ok) return ok.error();
  return frame;
}

Result<EncodedFrame> encode_frame(const SceneInput& in, const EncodeSettings& s) {
  auto p = prepare_pipeline(in, s);
  if (!p) return p.error();
  return encode_prepared(in, *p);
}

}  // namespace hdrd

#include "patterns/patterns.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "encode/pipeline.hpp"
#include "encode/colour/transfer.hpp"
#include "patterns/decode.hpp"
#include "patterns/font.hpp"

namespace hdrd::patterns {
namespace {

constexpr PatternInfo kPatterns[] = {
    {"bt2111", "HDR colour bars, PQ (--mode hdr10) or HLG (--mode hlg), 10-bit narrow range",
     "ITU-R BT.2111-2"},
    {"pq-ramp", "Steps of equal PQ signal from 0 to 10000 cd/m2, each labelled in cd/m2", "SMPTE ST 2084"},
    {"window", "A centred window of --area percent of the frame at --level cd/m2 on black",
     "peak-luminance windows as in VESA DisplayHDR CTS and ICDM IDMS 1.1"},
    {"near-black", "Labelled steps from 0.005 to 5 cd/m2 on a 0 cd/m2 background", "black-level (PLUGE-like) steps"},
    {"clipping", "Squares at 0.7, 0.8, 0.9, 0.95, 1, 1.05, 1.1, 1.25 and 1.5x --level (default: the display's "
                 "peak) on a 10000 cd/m2 background, encoded over the signal's full range (hdr10: 10000 cd/m2 "
                 "codes; nothing clipped by hdrd): on a display that clips at P the squares at and above P vanish; "
                 "the sidecar names each square's level",
     "HGIG HDR calibration guidelines (max-luminance clipping pattern)"},
    {"sdr-grey", "SDR signal steps 0..100 % decoded with the SDR EOTF and placed at the SDR white",
     "BT.2408 §5 (SDR white in an HDR frame)"},
    {"sdr-shadows", "SDR shadow steps (0..20 % signal) decoded three ways, one row each: sRGB piecewise, gamma 2.2, "
                    "BT.1886 (2.4), placed at the SDR white, labelled with the 8-bit code; > marks the SDR content EOTF",
     "IEC 61966-2-1, ITU-R BT.1886 (SDR content in an HDR frame)"},
};

std::string nits_label(double nits) {
  if (nits == 0) return "0";
  if (nits >= 100) return fmt::format("{:.0f}", nits);
  if (nits >= 10) return fmt::format("{:.1f}", nits);
  if (nits >= 1) return fmt::format("{:.2f}", nits);
  return fmt::format("{:.3f}", nits).substr(1);  // ".005"
}

struct Canvas {
  Image& img;
  void fill(int x0, int y0, int x1, int y1, double nits) {
    x0 = std::clamp(x0, 0, img.width), x1 = std::clamp(x1, 0, img.width);
    y0 = std::clamp(y0, 0, img.height), y1 = std::clamp(y1, 0, img.height);
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) set(x, y, nits);
  }
  void set(int x, int y, double nits) {
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
    float* p = img.px(x, y);
    p[0] = p[1] = p[2] = static_cast<float>(nits);
    p[3] = 1;
  }
  // Centred text of the given luminance, scaled to fit `max_width`; skipped if it cannot.
  void label(const std::string& text, int cx, int y, int max_width, int max_height, double nits) {
    int scale = std::min(3, std::max(1, max_height / (kGlyphHeight + 2)));
    while (scale > 1 && text_width(text, scale) > max_width) --scale;
    if (text_width(text, scale) > max_width || kGlyphHeight * scale > max_height) return;
    draw_text(text, cx - text_width(text, scale) / 2, y, scale, [&](int x, int yy) { set(x, yy, nits); });
  }
};

// Labels sit at a moderate level that every mode shows: the smaller of paper white and peak.
double label_nits(const DisplayTarget& t) { return std::min(t.paper_white_nits, t.peak_nits) * 0.5; }

// N patches in a row over the top 80 % of the frame, labels in the strip below.
void patch_row(Canvas& c, const std::vector<double>& levels, const std::vector<std::string>& labels,
               const DisplayTarget& t, bool draw_labels) {
  const int w = c.img.width, h = c.img.height, n = static_cast<int>(levels.size());
  const int strip = std::max(1, h / 5);
  for (int i = 0; i < n; ++i) {
    const int x0 = i * w / n, x1 = (i + 1) * w / n;
    c.fill(x0, 0, x1, h - strip, levels[static_cast<std::size_t>(i)]);
    if (draw_labels)
      c.label(labels[static_cast<std::size_t>(i)], (x0 + x1) / 2, h - strip + strip / 4, x1 - x0 - 2, strip / 2,
              label_nits(t));
  }
}

Image pq_ramp(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  const int steps = o.steps > 1 ? o.steps : 11;
  std::vector<double> levels;
  std::vector<std::string> labels;
  for (int i = 0; i < steps; ++i) {
    // Equal steps of PQ signal: perceptually uniform (ST 2084 is built on Barten's model).
    const double nits = transfer::pq_eotf(double(i) / (steps - 1));
    levels.push_back(nits);
    labels.push_back(nits_label(nits));
  }
  patch_row(c, levels, labels, t, o.labels);
  return img;
}

Image window(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  const double level = o.level_nits > 0 ? o.level_nits : t.peak_nits;
  const double side = std::sqrt(std::clamp(o.area_percent, 0.0, 100.0) / 100.0);
  const int ww = static_cast<int>(std::lround(o.width * side)), wh = static_cast<int>(std::lround(o.height * side));
  const int x0 = (o.width - ww) / 2, y0 = (o.height - wh) / 2;
  c.fill(x0, y0, x0 + ww, y0 + wh, level);
  return img;
}

Image near_black(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  static constexpr double kLevels[] = {0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5};
  const int steps = o.steps > 0 ? std::min<int>(o.steps, std::size(kLevels)) : static_cast<int>(std::size(kLevels));
  std::vector<double> levels(kLevels, kLevels + steps);
  std::vector<std::string> labels;
  for (double l : levels) labels.push_back(nits_label(l));
  // Patches are squares in the middle third of each column, so each sits on 0 cd/m2.
  const int w = o.width, h = o.height, strip = std::max(1, h / 5);
  for (int i = 0; i < steps; ++i) {
    const int x0 = i * w / steps, x1 = (i + 1) * w / steps, pad = (x1 - x0) / 6;
    c.fill(x0 + pad, h / 5, x1 - pad, h - strip - h / 10, levels[static_cast<std::size_t>(i)]);
    if (o.labels) c.label(labels[static_cast<std::size_t>(i)], (x0 + x1) / 2, h - strip + strip / 4, x1 - x0 - 2,
                          strip / 2, std::min(t.peak_nits, 20.0));
  }
  return img;
}

}  // namespace

// Ratios of --level the clipping squares sit at; shared with the tests through the sidecar.
static constexpr double kClipRatios[] = {0.7, 0.8, 0.9, 0.95, 1.0, 1.05, 1.1, 1.25, 1.5};

namespace {

Image clipping(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  const double level = o.level_nits > 0 ? o.level_nits : t.peak_nits;
  // The background at the PQ maximum: a display that clips at P shows every square whose
  // level is >= P as the background (HGIG: the square "disappears").
  c.fill(0, 0, o.width, o.height, transfer::kPqPeakNits);
  const int n = static_cast<int>(std::size(kClipRatios)), w = o.width, h = o.height;
  const int strip = std::max(1, h / 5);
  c.fill(0, h - strip, w, h, 0);
  for (int i = 0; i < n; ++i) {
    const int x0 = i * w / n, x1 = (i + 1) * w / n, side = std::min(x1 - x0, h - strip) / 2;
    const int cx = (x0 + x1) / 2, cy = (h - strip) / 2;
    c.fill(cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2, level * kClipRatios[i]);
    if (o.labels) c.label(nits_label(level * kClipRatios[i]), cx, h - strip + strip / 4, x1 - x0 - 2, strip / 2,
                          label_nits(t));
  }
  return img;
}

// Light of SDR signal v relative to its white: in an HDR frame the SDR content's EOTF
// (DisplayTarget::sdr_content_eotf); in SDR modes the display's own.
double sdr_relative(const DisplayTarget& t, double v) {
  if (t.is_hdr()) return sdr_eotf(t.sdr_content_eotf, v);
  if (t.mode == Mode::sdr_bt1886)
    return transfer::Bt1886::from_levels(t.peak_nits, t.black_nits).eotf(v) / t.peak_nits;
  return t.sdr_curve == SdrCurve::srgb ? transfer::srgb_eotf(v) : transfer::gamma22_eotf(v);
}

// SDR white in an HDR frame is the target's sdr_white_nits (BT.2408: 203 cd/m2); in SDR
// modes the display's own white.
double sdr_white(const DisplayTarget& t) { return t.is_hdr() ? t.sdr_white_nits : t.peak_nits; }

// SDR light relative to its white -> nits: in an HDR frame through ui.inverse_tonemap
// (sdr_light_to_nits), in SDR modes the display's own white.
double sdr_nits(const DisplayTarget& t, double light) {
  if (!t.is_hdr()) return light * t.peak_nits;
  return sdr_light_to_nits(t.sdr_inverse_tonemap, light, t.sdr_white_nits, t.peak_nits);
}

Image sdr_grey(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  const int steps = o.steps > 1 ? o.steps : 11;
  std::vector<double> levels;
  std::vector<std::string> labels;
  for (int i = 0; i < steps; ++i) {
    const double v = double(i) / (steps - 1);
    levels.push_back(sdr_nits(t, sdr_relative(t, v)));
    labels.push_back(fmt::format("{:.0f}%", v * 100));
  }
  patch_row(c, levels, labels, t, o.labels);
  return img;
}

Image sdr_shadows(const DisplayTarget& t, const PatternOptions& o) {
  Image img(o.width, o.height);
  Canvas c{img};
  const auto& signals = sdr_shadow_signals();
  const int n = static_cast<int>(signals.size()), w = o.width, h = o.height;
  const int strip = std::max(1, h / 8), label_w = w / 8;
  const int row_h = (h - strip) / 3;
  for (int r = 0; r < 3; ++r) {
    const SdrEotf e = kSdrShadowRows[r];
    const int y0 = r * row_h, y1 = y0 + row_h - std::max(1, row_h / 10);  // a black gap between rows
    for (int i = 0; i < n; ++i) {
      const int x0 = label_w + i * (w - label_w) / n, x1 = label_w + (i + 1) * (w - label_w) / n;
      c.fill(x0, y0, x1, y1, sdr_nits(t, sdr_eotf(e, signals[static_cast<std::size_t>(i)])));
    }
    if (o.labels) {
      const std::string name = (e == t.sdr_content_eotf ? ">" : "") + std::string(to_string(e));
      c.label(name, label_w / 2, y0 + row_h / 4, label_w - 2, row_h / 2, label_nits(t));
    }
  }
  if (o.labels)
    for (int i = 0; i < n; ++i) {
      const int x0 = label_w + i * (w - label_w) / n, x1 = label_w + (i + 1) * (w - label_w) / n;
      c.label(fmt::format("{}", std::lround(signals[static_cast<std::size_t>(i)] * 255)), (x0 + x1) / 2,
              h - strip + strip / 4, x1 - x0 - 2, strip / 2, label_nits(t));
    }
  return img;
}

}  // namespace

const std::vector<double>& sdr_shadow_signals() {
  // 8-bit codes 0, 3, 5, 8, 10, 13, 15, 20, 26, 38, 51 (as fractions of 255): where the
  // piecewise sRGB toe and the power laws differ most, relative to their level.
  static const std::vector<double> v = [] {
    std::vector<double> s;
    for (int code : {0, 3, 5, 8, 10, 13, 15, 20, 26, 38, 51}) s.push_back(code / 255.0);
    return s;
  }();
  return v;
}

std::span<const PatternInfo> patterns() { return kPatterns; }

const PatternInfo* find_pattern(std::string_view name) {
  for (const auto& p : kPatterns)
    if (p.name == name) return &p;
  return nullptr;
}

Result<Image> pattern_nits(std::string_view name, const DisplayTarget& t, const PatternOptions& o) {
  if (auto ok = check_image_size(o.width, o.height); !ok) return ok.error();
  if (o.area_percent <= 0 || o.area_percent > 100)
    return make_error("pattern.area", fmt::format("--area {} is not in (0, 100] percent", o.area_percent), "area");
  if (o.level_nits < 0 || o.level_nits > transfer::kPqPeakNits)
    return make_error("pattern.level", fmt::format("--level {} is not in [0, 10000] cd/m2", o.level_nits), "level");
  if (name == "pq-ramp") return pq_ramp(t, o);
  if (name == "window") return window(t, o);
  if (name == "near-black") return near_black(t, o);
  if (name == "clipping") return clipping(t, o);
  if (name == "sdr-grey") return sdr_grey(t, o);
  if (name == "sdr-shadows") return sdr_shadows(t, o);
  if (name == "bt2111")
    return make_error("pattern.codes", "bt2111 is defined as code values, not display light", "pattern");
  return make_error("pattern.unknown", fmt::format("unknown pattern '{}' (see hdrd pattern --list)", name), "pattern");
}

Result<EncodedFrame> encode_display_nits(const Image& nits, const DisplayTarget& target, bool keep_display_nits) {
  EncodeSettings s;
  s.target = target;
  s.exposure.mode = exposure::Mode::manual;
  s.tone.curve = "clip";
  s.gamut = GamutMapping::clip;
  s.keep_display_nits = keep_display_nits;
  s.png_samples = true;
  s.threads = 0;
  SceneInput in;
  in.image = &nits;
  in.to_working = color::to_working(color::Space::rec2020);
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  return encode_frame(in, s);
}

Result<EncodedFrame> frame_from_codes(const std::vector<Code3>& codes, int width, int height,
                                      const DisplayTarget& target, bool keep_display_nits) {
  if (target.bits != 10 || target.mode == Mode::scrgb)
    return make_error("pattern.codes", "code patterns need a 10-bit hdr10, hlg or SDR target", "mode");
  if (codes.size() != static_cast<std::size_t>(width) * height)
    return make_error("pattern.codes", "code count does not match the frame size");
  EncodedFrame f;
  f.target = target;
  f.width = width, f.height = height;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = static_cast<std::size_t>(width) * 4;
  f.data.resize(f.stride_bytes * height);
  f.signal16.resize(static_cast<std::size_t>(width) * height * 3);
  if (keep_display_nits) f.display_nits = Image(width, height);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    const int c[3] = {codes[i].r, codes[i].g, codes[i].b};
    const std::uint32_t word = std::uint32_t(c[0]) | (std::uint32_t(c[1]) << 10) | (std::uint32_t(c[2]) << 20);
    std::memcpy(f.data.data() + i * 4, &word, 4);
    for (int k = 0; k < 3; ++k) {
      const double e = std::clamp(code_to_signal(target, c[k]), 0.0, 1.0);
      f.signal16[i * 3 + k] = static_cast<std::uint16_t>(std::lround(e * 65535));
    }
    if (keep_display_nits) {
      const color::Vec3 n = decode_codes(target, c);
      float* p = f.display_nits->rgba.data() + i * 4;
      p[0] = float(n.x), p[1] = float(n.y), p[2] = float(n.z), p[3] = 1;
    }
  }
  f.content_light = measure_content_light(f);
  f.mastering = target.mastering();
  return f;
}

Result<EncodedFrame> make_pattern(std::string_view name, const DisplayTarget& target, const PatternOptions& o,
                                  bool keep_display_nits) {
  const PatternInfo* info = find_pattern(name);
  if (!info)
    return make_error("pattern.unknown", fmt::format("unknown pattern '{}' (see hdrd pattern --list)", name), "pattern");
  nlohmann::json desc = {{"name", info->name}, {"source", info->source}, {"width", o.width}, {"height", o.height}};
  Result<EncodedFrame> frame = make_error("internal", "pattern not built");
  if (name == "bt2111") {
    if (target.mode != Mode::hdr10 && target.mode != Mode::hlg)
      return make_error("pattern.mode", "bt2111 bars exist for PQ (--mode hdr10) and HLG (--mode hlg) only", "mode");
    if (auto ok = check_image_size(o.width, o.height); !ok) return ok.error();
    DisplayTarget t = target;
    t.range = Range::narrow;  // the standard defines the narrow-range signal
    t.bits = 10;
    const auto sys = t.mode == Mode::hlg ? Bt2111System::hlg : Bt2111System::pq;
    frame = frame_from_codes(bt2111_codes(sys, o.width, o.height), o.width, o.height, t, keep_display_nits);
    desc["range"] = "narrow";
  } else {
    auto nits = pattern_nits(name, target, o);
    if (!nits) return nits.error();
    // The clipping pattern probes where the display clips, so hdrd must not clip it first:
    // PQ's signal covers 10000 cd/m2 whatever the display's peak (the squares' default level),
    // so it is encoded for that range. HLG and SDR signals end at the display's peak.
    DisplayTarget encoded = target;
    if (name == "clipping" && target.mode == Mode::hdr10) encoded.peak_nits = transfer::kPqPeakNits;
    frame = encode_display_nits(*nits, encoded, keep_display_nits);
    const double level = o.level_nits > 0 ? o.level_nits : target.peak_nits;
    if (name == "window") desc["level_nits"] = level, desc["area_percent"] = o.area_percent;
    if (name == "sdr-shadows") {
      desc["rows"] = nlohmann::json::array();
      for (SdrEotf e : kSdrShadowRows) desc["rows"].push_back(to_string(e));
      desc["signals"] = sdr_shadow_signals();
      desc["sdr_white_nits"] = sdr_white(target);
      desc["sdr_content_eotf"] = to_string(target.sdr_content_eotf);
    }
    if (name == "clipping") {
      desc["level_nits"] = level;
      desc["square_nits"] = nlohmann::json::array();
      for (double r : kClipRatios) desc["square_nits"].push_back(level * r);
      desc["background_nits"] = transfer::kPqPeakNits;
      desc["display_peak_nits"] = target.peak_nits;
      desc["signal_peak_nits"] = encoded.peak_nits;  // what the codes cover: nothing above it is clipped by hdrd
    }
    if (level * (name == "clipping" ? kClipRatios[std::size(kClipRatios) - 1] : 1.0) > encoded.peak_nits &&
        (name == "window" || name == "clipping"))
      desc["note"] = fmt::format("level {} cd/m2 is above the signal's peak {} cd/m2: the encoder clips it", level,
                                 encoded.peak_nits);
  }
  if (!frame) return frame.error();
  frame->settings["pattern"] = desc;
  return frame;
}

}  // namespace hdrd::patterns

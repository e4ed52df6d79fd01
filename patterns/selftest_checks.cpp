// The display-mode suite's check functions. Expected values come from the standards
// (transfer functions of encode/colour/transfer.hpp evaluated in double precision, and the
// published numbers where one exists); measured values are decoded from the frame's own
// bytes with patterns/decode.hpp.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "encode/tone/tonemap.hpp"
#include "encode/colour/transfer.hpp"
#include "patterns/decode.hpp"
#include "patterns/patterns.hpp"
#include "patterns/selftest.hpp"

namespace hdrd::patterns {
namespace {

Check make(std::string name, std::string source, bool passed, std::string detail) {
  return Check{std::move(name), std::move(source), passed, false, std::move(detail)};
}

int max_code(const DisplayTarget& t) { return (1 << t.bits) - 1; }
int quantize(const DisplayTarget& t, double signal) {
  return t.range == Range::narrow ? transfer::quantize_narrow(signal, t.bits) : transfer::quantize_full(signal, t.bits);
}

// The largest code whose light is at most the display peak, where the encoder clips
// (ST 2084 decoded here; the other transfers end at the peak).
int peak_code(const DisplayTarget& t) {
  int c = t.range == Range::narrow ? quantize(t, 1.0) : max_code(t);
  if (t.mode != Mode::hdr10) return c;
  while (c > 0 && transfer::pq_eotf(std::clamp(code_to_signal(t, c), 0.0, 1.0)) > t.peak_nits) --c;
  return c;
}

// The code paper white must land on, and the source that says so.
std::pair<int, std::string> paper_white_code(const DisplayTarget& t) {
  const double pw = t.paper_white_nits;
  switch (t.mode) {
    case Mode::hdr10:
      if (pw == 203 && t.range == Range::full && t.bits == 10 && t.peak_nits >= pw)
        return {594, "BT.2408-7 §2: 203 cd/m2 -> PQ 58 %, code 594 (10-bit full range)"};
      return {std::min(quantize(t, transfer::pq_inverse_eotf(pw)), peak_code(t)),
              "SMPTE ST 2084 inverse EOTF of paper white (at most the peak's code)"};
    case Mode::hlg:
      if (pw == 203 && t.peak_nits == 1000)
        return {quantize(t, 0.75), "BT.2408-7 §2: 203 cd/m2 on a 1000 cd/m2 HLG display -> HLG 75 %"};
      return {quantize(t, transfer::hlg_inverse_eotf({pw, pw, pw}, t.peak_nits, t.black_nits).x),
              "BT.2100 HLG inverse EOTF of paper white at the display peak"};
    case Mode::sdr:
    case Mode::sdr_bt1886:
      if (pw >= t.peak_nits) return {max_code(t), "SDR: paper white is the display's white (code max)"};
      return {quantize(t, t.mode == Mode::sdr ? transfer::srgb_inverse_eotf(pw / t.peak_nits)
                                              : transfer::Bt1886::from_levels(t.peak_nits, t.black_nits).inverse_eotf(pw)),
              "SDR inverse EOTF of paper white"};
    case Mode::scrgb: break;
  }
  return {0, ""};
}

color::Vec3 to_rec2020(const DisplayTarget& t, color::Vec3 container) {
  if (t.container() == color::kRec2020) return container;
  return color::rgb_to_rgb(t.container(), color::kRec2020) * container;
}

}  // namespace

Check check_paper_white(const EncodedFrame& f, const std::string& curve, int tolerance) {
  const std::string name = "paper-white/" + curve;
  const int cx = f.width / 2, cy = f.height / 2;
  const PixelSignal p = read_pixel(f, cx, cy);
  if (f.target.mode == Mode::scrgb) {
    const double want = f.target.paper_white_nits / transfer::kScrgbUnitNits;
    const double worst = std::max({std::abs(p.scrgb[0] - want), std::abs(p.scrgb[1] - want), std::abs(p.scrgb[2] - want)});
    // One half-float step at 2..4 is 2^-9.
    return make(name, fmt::format("IEC 61966-2-2 scRGB: 1.0 = 80 cd/m2, paper white {} -> {:.4f}",
                                  f.target.paper_white_nits, want),
                worst <= std::ldexp(1.0, -9),
                fmt::format("({:.4f}, {:.4f}, {:.4f}) vs {:.4f}", p.scrgb[0], p.scrgb[1], p.scrgb[2], want));
  }
  const auto [want, source] = paper_white_code(f.target);
  int worst = 0;
  for (int c : p.code) worst = std::max(worst, std::abs(c - want));
  return make(name, source, worst <= tolerance,
              fmt::format("codes ({}, {}, {}) vs {} (tolerance {})", p.code[0], p.code[1], p.code[2], want, tolerance));
}

Check check_rec709_primaries(const EncodedFrame& f, const std::string& what) {
  const color::Chromaticity want[3] = {color::kRec709.red, color::kRec709.green, color::kRec709.blue};
  const color::Mat3 to_xyz = color::rgb_to_xyz(f.target.container());
  double worst = 0;
  std::string detail;
  // Measured above the display's black (as colorimeters subtract flare): BT.1886 decodes
  // the primaries' zero channels to the black level, which is the display, not the signal.
  const int zero[3] = {0, 0, 0};
  const color::Vec3 black = f.target.mode == Mode::scrgb ? color::Vec3{} : decode_codes(f.target, zero);
  for (int i = 0; i < 3; ++i) {
    const color::Vec3 n = decode_pixel(f, (2 * i + 1) * f.width / 6, f.height / 2) - black;
    const color::Vec3 xyz = to_xyz * n;
    const double s = xyz.x + xyz.y + xyz.z;
    const double x = s > 0 ? xyz.x / s : 0, y = s > 0 ? xyz.y / s : 0;
    worst = std::max({worst, std::abs(x - want[i].x), std::abs(y - want[i].y)});
    detail += fmt::format("{}({:.4f},{:.4f}) ", "RGB"[i], x, y);
  }
  // 10-bit quantisation of a primary moves its chromaticity by a few 1e-4.
  return make("rec709-primaries/" + what, "BT.709 primaries carried in the BT.2020 container (BT.2087)",
              worst <= 0.003, detail + fmt::format("max deviation {:.4f} (limit 0.003)", worst));
}

Check check_peak(const EncodedFrame& f, const std::string& what) {
  const DisplayTarget& t = f.target;
  const std::string name = "peak/" + what;
  // One rule in every mode: no pixel's channel decodes above the display peak (the largest
  // code at or below it, not the nearest code to it, which half of all integer PQ peaks put
  // above). For the code modes to 1e-6 (the decoder's float arithmetic; one code near the
  // peak is ~0.3 %); scRGB's half floats keep their rounding (2^-11).
  double highest = 0;
  int highest_code = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const color::Vec3 n = to_rec2020(t, decode_pixel(f, x, y));
      highest = std::max({highest, n.x, n.y, n.z});
      if (t.mode != Mode::scrgb)
        for (int c : read_pixel(f, x, y).code) highest_code = std::max(highest_code, c);
    }
  const double tolerance = t.mode == Mode::scrgb ? std::ldexp(1.0, -11) : 1e-6;
  const std::string code = t.mode == Mode::scrgb ? "" : fmt::format(" (code {})", highest_code);
  return make(name,
              t.mode == Mode::hdr10 ? "ST 2084 / ST 2086: no code decodes above the display peak"
                                    : "display light never above the display peak (REFERENCE.md §1.4)",
              highest <= t.peak_nits * (1 + tolerance),
              fmt::format("brightest channel {:.4f} cd/m2{} vs peak {} cd/m2", highest, code, t.peak_nits));
}

ContentLightLevel decode_content_light(const EncodedFrame& f) {
  double max_cll = 0, sum = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const color::Vec3 n = to_rec2020(f.target, decode_pixel(f, x, y));
      const double m = std::max({n.x, n.y, n.z, 0.0});
      max_cll = std::max(max_cll, m);
      sum += m;
    }
  const double count = double(f.width) * f.height;
  return {max_cll, count > 0 ? sum / count : 0};
}

Check check_content_light(const EncodedFrame& f, const std::string& what) {
  const std::string name = "content-light/" + what;
  if (!f.target.is_hdr()) {
    Check c = make(name, "CTA-861.3 (HDR modes only)", true, "SDR frame: no content light level");
    c.skipped = true;
    return c;
  }
  const ContentLightLevel mine = decode_content_light(f);
  auto close = [](double a, double b) { return std::abs(a - b) <= 0.01 + 2e-3 * std::max(a, b); };
  const bool ok = close(mine.max_cll_nits, f.content_light.max_cll_nits) &&
                  close(mine.max_fall_nits, f.content_light.max_fall_nits);
  return make(name, "CTA-861.3 §A: MaxCLL = max of max(R,G,B), MaxFALL = max frame mean, decoded from the codes", ok,
              fmt::format("frame says {:.2f}/{:.2f}, decoded {:.2f}/{:.2f} cd/m2", f.content_light.max_cll_nits,
                          f.content_light.max_fall_nits, mine.max_cll_nits, mine.max_fall_nits));
}

Check check_metadata_blob(const EncodedFrame& f, std::span<const std::uint8_t> b) {
  const std::string name = "metadata-blob";
  const std::string source = "CTA-861-G §6.9 Table 44/45, linux struct hdr_output_metadata (little-endian)";
  if (b.size() != 32) return make(name, source, false, fmt::format("{} bytes, want 32", b.size()));
  auto u16 = [&](std::size_t at) { return int(b[at]) | (int(b[at + 1]) << 8); };
  const std::uint32_t type = b[0] | (b[1] << 8) | (b[2] << 16) | (std::uint32_t(b[3]) << 24);
  const int want_eotf = f.target.mode == Mode::hlg ? 3 : 2;
  std::vector<std::string> bad;
  if (type != 0 || b[5] != 0) bad.push_back("static metadata type is not 1 (value 0)");
  if (b[4] != want_eotf) bad.push_back(fmt::format("EOTF byte {} want {}", b[4], want_eotf));
  const MasteringDisplay& m = f.mastering;
  const color::Chromaticity xy[4] = {m.primaries.red, m.primaries.green, m.primaries.blue, m.primaries.white};
  for (int i = 0; i < 4; ++i) {
    const int wx = int(std::lround(xy[i].x / 0.00002)), wy = int(std::lround(xy[i].y / 0.00002));
    if (std::abs(u16(6 + 4 * i) - wx) > 1 || std::abs(u16(8 + 4 * i) - wy) > 1)
      bad.push_back(fmt::format("chromaticity {} is ({}, {}) want ({}, {})", i, u16(6 + 4 * i), u16(8 + 4 * i), wx, wy));
  }
  if (u16(22) != int(std::lround(m.max_nits))) bad.push_back(fmt::format("max luminance {} want {}", u16(22), m.max_nits));
  if (std::abs(u16(24) - int(std::lround(m.min_nits * 10000))) > 1)
    bad.push_back(fmt::format("min luminance {} want {}", u16(24), m.min_nits * 10000));
  const ContentLightLevel mine = decode_content_light(f);
  auto want_level = [&](double v) { return v > 0 ? int(std::ceil(v - 1e-6)) : int(std::lround(m.max_nits)); };
  if (std::abs(u16(26) - want_level(mine.max_cll_nits)) > 1) bad.push_back(fmt::format("MaxCLL {} want {}", u16(26), want_level(mine.max_cll_nits)));
  if (std::abs(u16(28) - want_level(mine.max_fall_nits)) > 1) bad.push_back(fmt::format("MaxFALL {} want {}", u16(28), want_level(mine.max_fall_nits)));
  std::string detail = bad.empty() ? fmt::format("EOTF {}, max {} cd/m2, MaxCLL {}, MaxFALL {}", b[4], u16(22), u16(26), u16(28)) : "";
  for (const auto& s : bad) detail += (detail.empty() ? "" : "; ") + s;
  return make(name, source, bad.empty(), detail);
}

Check check_png(const EncodedFrame& f, const io::PngInfo& png) {
  const DisplayTarget& t = f.target;
  std::vector<std::string> bad;
  if (png.width != f.width || png.height != f.height) bad.push_back("size differs from the frame");
  const int want_depth = t.bits == 8 ? 8 : 16;
  if (png.bit_depth != want_depth) bad.push_back(fmt::format("bit depth {} want {}", png.bit_depth, want_depth));
  // H.273: primaries 9 = BT.2020, 1 = BT.709; transfer 16 = PQ, 18 = HLG, 13 = sRGB,
  // 4 = gamma 2.2, 1 = BT.709 (BT.1886 display); matrix 0 = RGB; range flag 1 = full.
  std::uint8_t prim = t.is_hdr() ? 9 : 1, tc = 13;
  if (t.mode == Mode::hdr10) tc = 16;
  if (t.mode == Mode::hlg) tc = 18;
  if (t.mode == Mode::sdr && t.sdr_curve == SdrCurve::gamma22) tc = 4;
  if (t.mode == Mode::sdr_bt1886) tc = 1;
  const std::array<std::uint8_t, 4> want{prim, tc, 0, std::uint8_t(t.range == Range::full ? 1 : 0)};
  if (want_depth == 16 && !png.cicp) bad.push_back("no cICP chunk");
  if (png.cicp && *png.cicp != want)
    bad.push_back(fmt::format("cICP {},{},{},{} want {},{},{},{}", (*png.cicp)[0], (*png.cicp)[1], (*png.cicp)[2],
                              (*png.cicp)[3], want[0], want[1], want[2], want[3]));
  if (t.mode == Mode::hdr10 || t.mode == Mode::hlg) {
    auto be32 = [](const std::vector<std::uint8_t>& v, std::size_t at) {
      return (std::uint32_t(v[at]) << 24) | (std::uint32_t(v[at + 1]) << 16) | (std::uint32_t(v[at + 2]) << 8) | v[at + 3];
    };
    if (!png.mdcv || png.mdcv->size() != 24) bad.push_back("no 24-byte mDCV chunk");
    else if (std::llabs(std::int64_t(be32(*png.mdcv, 16)) - std::llround(f.mastering.max_nits * 10000)) > 1)
      bad.push_back(fmt::format("mDCV max luminance {} want {}", be32(*png.mdcv, 16), f.mastering.max_nits * 10000));
    if (!png.clli || png.clli->size() != 8) bad.push_back("no 8-byte cLLI chunk");
    else {
      const ContentLightLevel mine = decode_content_light(f);
      const double cll = be32(*png.clli, 0) / 10000.0, fall = be32(*png.clli, 4) / 10000.0;
      if (std::abs(cll - mine.max_cll_nits) > 1.0 || std::abs(fall - mine.max_fall_nits) > 1.0)
        bad.push_back(fmt::format("cLLI {}/{} vs decoded {:.2f}/{:.2f}", cll, fall, mine.max_cll_nits, mine.max_fall_nits));
    }
  }
  std::string detail = bad.empty() ? fmt::format("{}-bit, cICP {},{},{},{}", png.bit_depth, want[0], want[1], want[2], want[3]) : "";
  for (const auto& s : bad) detail += (detail.empty() ? "" : "; ") + s;
  return make("png-chunks", "PNG 3rd edition cICP/mDCV/cLLI, ITU-T H.273 code points", bad.empty(), detail);
}

Check check_exr(const EncodedFrame& f, const io::ExrImage& exr) {
  std::vector<std::string> bad;
  const DisplayTarget& t = f.target;
  if (!exr.chromaticities || *exr.chromaticities != t.container()) bad.push_back("chromaticities are not the container's");
  const double white = t.mode == Mode::scrgb ? transfer::kScrgbUnitNits : t.paper_white_nits;
  if (!exr.white_luminance || std::abs(*exr.white_luminance - white) > 1e-3)
    bad.push_back(fmt::format("whiteLuminance {} want {}", exr.white_luminance.value_or(-1), white));
  if (!exr.attributes.count("mode") && !exr.attributes.count("hdrd:mode")) bad.push_back("no mode attribute");
  if (exr.image.width != f.width || exr.image.height != f.height) bad.push_back("size differs");
  else {
    // The EXR holds the light before quantisation: allow half a code (8-bit sRGB steps are
    // up to 4 % in the shadows) and half-float rounding.
    // BT.1886 decodes code 0 to the display black: allow that lift in the shadows too.
    const double rel_tol = t.bits == 8 ? 0.04 : 0.01;
    const double floor_nits = (t.bits == 8 ? 0.1 : 0.05) + (t.mode == Mode::sdr_bt1886 ? 2 * t.black_nits : 0);
    double worst = 0;
    for (int y = 0; y < f.height; y += std::max(1, f.height / 8))
      for (int x = 0; x < f.width; x += std::max(1, f.width / 8)) {
        const color::Vec3 n = decode_pixel(f, x, y);
        const float* p = exr.image.px(x, y);
        for (int c = 0; c < 3; ++c) {
          const double stored = p[c] * white, want = n[c];
          worst = std::max(worst, std::abs(stored - want) / std::max(floor_nits / rel_tol, std::abs(want)) / rel_tol);
        }
      }
    if (worst > 1) bad.push_back(fmt::format("pixels differ from the decoded codes by {:.2f}x the tolerance", worst));
  }
  std::string detail = bad.empty() ? fmt::format("chromaticities = container, whiteLuminance {}", white) : "";
  for (const auto& s : bad) detail += (detail.empty() ? "" : "; ") + s;
  return make("exr-attributes", "OpenEXR chromaticities/whiteLuminance (docs/dump-format.md)", bad.empty(), detail);
}

std::vector<Check> check_curves_monotonic(const DisplayTarget& t) {
  std::vector<Check> out;
  const tonemap::Display d{t.peak_nits, t.black_nits, t.paper_white_nits};
  for (const auto& info : tonemap::curves()) {
    auto curve = tonemap::prepare(info.name, d);
    const std::string name = "monotonic/" + std::string(info.name);
    if (!curve) {
      out.push_back(make(name, std::string(info.source), false, curve.error().message));
      continue;
    }
    double prev = 0, worst_drop = 0, top = 0;
    for (int i = 0; i <= 400; ++i) {
      const double x = std::pow(10.0, -4 + 8.0 * i / 400);  // 1e-4 .. 1e4 relative
      const double y = (*curve)->map(x);
      if (!std::isfinite(y)) { worst_drop = INFINITY; break; }
      worst_drop = std::max(worst_drop, prev - y);
      prev = std::max(prev, y);
      top = std::max(top, y);
    }
    const bool ok = worst_drop <= 1e-9 * std::max(1.0, top) && top <= d.max_y() * (1 + 1e-6);
    out.push_back(make(name, "tone curves are non-decreasing and within the display maximum (REFERENCE.md §1.3)", ok,
                       fmt::format("largest drop {:.3g}, max {:.4g} vs display max {:.4g} (paper-white units)",
                                   worst_drop, top, d.max_y())));
  }
  return out;
}

Check check_window(const EncodedFrame& f, double level_nits) {
  const DisplayTarget& t = f.target;
  const PixelSignal p = read_pixel(f, f.width / 2, f.height / 2);
  const double target_nits = std::min(level_nits, t.peak_nits);
  int want = 0;
  if (t.mode == Mode::hdr10) want = std::min(quantize(t, transfer::pq_inverse_eotf(target_nits)), peak_code(t));
  else if (t.mode == Mode::hlg)
    want = quantize(t, transfer::hlg_inverse_eotf({target_nits, target_nits, target_nits}, t.peak_nits, t.black_nits).x);
  else if (t.mode == Mode::sdr) want = quantize(t, transfer::srgb_inverse_eotf(target_nits / t.peak_nits));
  else if (t.mode == Mode::sdr_bt1886) want = quantize(t, transfer::Bt1886::from_levels(t.peak_nits, t.black_nits).inverse_eotf(target_nits));
  else {
    const double v = p.scrgb[0] * transfer::kScrgbUnitNits;
    return make("window", "IEC 61966-2-2: scRGB value x 80 = cd/m2", std::abs(v - target_nits) <= 2e-3 * target_nits,
                fmt::format("{:.2f} cd/m2 vs {:.2f}", v, target_nits));
  }
  int worst = 0;
  for (int c : p.code) worst = std::max(worst, std::abs(c - want));
  return make("window", "window level within 1 code of the requested luminance (transfer of the mode)", worst <= 1,
              fmt::format("codes ({}, {}, {}) vs {} for {} cd/m2", p.code[0], p.code[1], p.code[2], want, target_nits));
}

}  // namespace hdrd::patterns

namespace hdrd::patterns {
namespace {

// The signal E' of grey display light `nits` in the frame's mode, from the standards
// (ST 2084, BT.2100 HLG with the target's black, IEC 61966-2-1 / 2.2, BT.1886).
double grey_signal(const DisplayTarget& t, double nits) {
  switch (t.mode) {
    case Mode::hdr10: return transfer::pq_inverse_eotf(nits);
    case Mode::hlg: return transfer::hlg_inverse_eotf({nits, nits, nits}, t.peak_nits, t.black_nits).x;
    case Mode::sdr: {
      const double l = std::clamp(nits / t.peak_nits, 0.0, 1.0);
      return t.sdr_curve == SdrCurve::srgb ? transfer::srgb_inverse_eotf(l) : transfer::gamma22_inverse_eotf(l);
    }
    case Mode::sdr_bt1886: return transfer::Bt1886::from_levels(t.peak_nits, t.black_nits).inverse_eotf(nits);
    case Mode::scrgb: return nits / transfer::kScrgbUnitNits;
  }
  return 0;
}

// How far pixel (x, y)'s channels are from grey light `nits`: in codes, and where the frame
// has 16-bit PNG samples (full range) in those steps too; scRGB in half-float relative error
// x 1000 (both fields). The larger of the two is what the checks hold to one step.
struct StepsOff {
  double codes = 0, samples16 = 0;
  double worst() const { return std::max(codes, samples16); }
};
StepsOff grey_steps_off(const EncodedFrame& f, int x, int y, double nits) {
  const DisplayTarget& t = f.target;
  const double e = grey_signal(t, nits);
  StepsOff off;
  if (t.mode == Mode::scrgb) {
    const PixelSignal p = read_pixel(f, x, y);
    for (double v : p.scrgb) off.codes = std::max(off.codes, std::abs(v - e) / std::max(std::abs(e), 1e-3) * 1000);
    off.samples16 = off.codes;
    return off;
  }
  const int want = quantize(t, e);
  for (int c : read_pixel(f, x, y).code) off.codes = std::max(off.codes, double(std::abs(c - want)));
  if (!f.signal16.empty() && t.range == Range::full) {
    const double want16 = std::clamp(e, 0.0, 1.0) * 65535;
    for (int c = 0; c < 3; ++c)
      off.samples16 = std::max(off.samples16, std::abs(f.signal16[(static_cast<std::size_t>(y) * f.width + x) * 3 + c] - want16));
    off.samples16 = std::max(0.0, off.samples16 - 0.5);  // the sample is rounded
  }
  return off;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : "; ") + x;
  return s;
}

}  // namespace

Check check_display_volume(const EncodedFrame& f, const std::string& what) {
  const std::string name = "display-volume/" + what;
  const std::string source = "the dump is the light a display decodes from the codes: BT.2100 EOTF (PQ; HLG at the "
                             "target's peak and black), BT.1886, IEC 61966-2-1";
  if (!f.display_nits) return make(name, source, false, "the frame has no display light (dump) to compare");
  double worst = 0;
  int wx = 0, wy = 0;
  const bool codes = f.target.mode != Mode::scrgb;
  const int top_code = (1 << f.target.bits) - 1;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const color::Vec3 n = decode_pixel(f, x, y);
      const float* p = f.display_nits->px(x, y);
      const double top = std::max({n.x, n.y, n.z, 1e-3});
      const PixelSignal sig = read_pixel(f, x, y);
      for (int c = 0; c < 3; ++c) {
        // 1 % of the channel (near 0: of 1 % of the pixel's brightest channel), or half the
        // light between the codes either side (the dump is before quantisation: 8-bit SDR
        // shadows step by several per cent).
        double tolerance = 0.01 * std::max(std::abs(n[c]), 0.01 * top);
        if (codes) {
          int up[3] = {sig.code[0], sig.code[1], sig.code[2]}, down[3] = {sig.code[0], sig.code[1], sig.code[2]};
          up[c] = std::min(up[c] + 1, top_code), down[c] = std::max(down[c] - 1, 0);
          tolerance = std::max(tolerance, 0.5 * (decode_codes(f.target, up)[c] - decode_codes(f.target, down)[c]));
        }
        const double off = std::abs(p[c] - n[c]) / tolerance;
        if (off > worst) worst = off, wx = x, wy = y;
      }
    }
  const color::Vec3 n = decode_pixel(f, wx, wy);
  const float* p = f.display_nits->px(wx, wy);
  return make(name, source, worst <= 1,
              fmt::format("worst pixel ({}, {}): dump ({:.2f}, {:.2f}, {:.2f}) vs decoded ({:.2f}, {:.2f}, {:.2f}) cd/m2, "
                          "{:.2f}x the tolerance (1 %, or half a code's light)",
                          wx, wy, p[0], p[1], p[2], n.x, n.y, n.z, worst));
}

Check check_tone_kinks(const EncodedFrame& f, const tonemap::Curve& curve, std::span<const double> xs,
                       const std::string& curve_name, std::span<const double> kinks) {
  const std::string name = "tone-kinks/" + curve_name;
  const std::string source = "the fast path's tone tables against the curve at and around its kinks (found "
                             "numerically), through the mode's inverse EOTF";
  StepsOff worst;
  std::size_t at = 0;
  for (std::size_t i = 0; i < xs.size() && static_cast<int>(i) < f.width * f.height; ++i) {
    const double nits = curve.map(xs[i]) * f.target.paper_white_nits;
    const StepsOff off = grey_steps_off(f, static_cast<int>(i % f.width), static_cast<int>(i / f.width), nits);
    if (off.worst() > worst.worst()) worst = off, at = i;
  }
  std::string ks;
  for (double k : kinks) ks += fmt::format("{}{:.6g}", ks.empty() ? "" : ", ", k);
  return make(name, source, worst.worst() <= 1.0,
              fmt::format("kinks at x = [{}]; worst at x = {:.9g}: {:.2f} codes, {:.2f} 16-bit steps off", ks,
                          xs.empty() ? 0.0 : xs[at], worst.codes, worst.samples16));
}

Check check_black_frame_metadata(const EncodedFrame& f, const nlohmann::json& sidecar, const io::PngInfo* png,
                                 std::span<const std::uint8_t> blob) {
  const std::string name = "black-frame-metadata";
  const std::string source = "REFERENCE.md §6: MaxCLL/MaxFALL that would be 0 (CTA-861.3: unknown) carry the "
                             "mastering peak, the same in the sidecar, PNG cLLI and HDR_OUTPUT_METADATA";
  // The mastering maximum in whole cd/m2, rounded down: no carried level may exceed it.
  const int want = std::max(1, static_cast<int>(std::floor(f.mastering.max_nits + 1e-6)));
  std::vector<std::string> seen, bad;
  auto expect = [&](const std::string& where, double cll, double fall) {
    seen.push_back(fmt::format("{} {:g}/{:g}", where, cll, fall));
    if (cll != want || fall != want) bad.push_back(fmt::format("{} says {:g}/{:g}, want {}/{}", where, cll, fall, want, want));
  };
  const auto& level = sidecar.contains("content_light_level") ? sidecar["content_light_level"] : nlohmann::json();
  if (!level.is_object() || !level.contains("max_cll_nits")) bad.push_back("the sidecar has no content_light_level");
  else expect("sidecar", level["max_cll_nits"].get<double>(), level["max_fall_nits"].get<double>());
  if (png) {
    if (!png->clli || png->clli->size() != 8) bad.push_back("the PNG has no 8-bit cLLI chunk");
    else {
      const auto& v = *png->clli;
      auto be32 = [&](std::size_t i) {
        return (std::uint32_t(v[i]) << 24) | (std::uint32_t(v[i + 1]) << 16) | (std::uint32_t(v[i + 2]) << 8) | v[i + 3];
      };
      expect("PNG cLLI", be32(0) / 10000.0, be32(4) / 10000.0);
    }
  }
  if (!blob.empty()) {
    if (blob.size() < 30) bad.push_back("HDR_OUTPUT_METADATA is shorter than 30 bytes");
    else expect("HDR_OUTPUT_METADATA", blob[26] | (blob[27] << 8), blob[28] | (blob[29] << 8));
  }
  return make(name, source, bad.empty(), bad.empty() ? joined(seen) : joined(bad));
}

Check check_sdr_content(const EncodedFrame& f, std::span<const int> codes8, double ui_white_nits) {
  const DisplayTarget& t = f.target;
  const SdrEotf e = t.sdr_content_eotf;
  const std::string name = "sdr-content/" + std::string(to_string(e));
  const std::string source = "SDR content (the UI) decoded with its EOTF (IEC 61966-2-1 sRGB, 2.2, BT.1886 2.4) "
                             "and placed at UI white";
  auto relative = [&](double v) {
    switch (e) {  // written from the standards here, not through the encoder's sdr_eotf
      case SdrEotf::srgb: return transfer::srgb_eotf(v);
      case SdrEotf::gamma22: return std::pow(v, 2.2);
      case SdrEotf::bt1886: return std::pow(v, 2.4);
    }
    return v;
  };
  const int n = static_cast<int>(codes8.size());
  StepsOff worst;
  std::string detail;
  for (int i = 0; i < n; ++i) {
    const int x = (2 * i + 1) * f.width / (2 * n);
    const double nits = ui_white_nits * relative(codes8[static_cast<std::size_t>(i)] / 255.0);
    const StepsOff off = grey_steps_off(f, x, f.height / 2, nits);
    if (off.worst() > worst.worst()) worst = off;
    if (codes8[static_cast<std::size_t>(i)] == 10)
      detail = fmt::format("8-bit code 10 -> {:.4f} cd/m2 (decoded {:.4f}); ", nits, decode_pixel(f, x, f.height / 2).y);
  }
  return make(name, source, worst.worst() <= 1.0,
              detail + fmt::format("worst {:.2f} codes, {:.2f} 16-bit steps off", worst.codes, worst.samples16));
}

Check check_sdr_shadows(const EncodedFrame& f) {
  const DisplayTarget& t = f.target;
  const std::string source = "the sdr-shadows pattern: row r decodes to SDR white x EOTF_r(signal) "
                             "(IEC 61966-2-1, 2.2, BT.1886 2.4)";
  const auto& signals = sdr_shadow_signals();
  const double white = t.is_hdr() ? t.sdr_white_nits : t.peak_nits;
  const int n = static_cast<int>(signals.size()), label_w = f.width / 8;
  const int row_h = (f.height - std::max(1, f.height / 8)) / 3;
  StepsOff worst;
  for (int r = 0; r < 3; ++r)
    for (int i = 0; i < n; ++i) {
      const double v = signals[static_cast<std::size_t>(i)];
      const double rel = r == 0 ? transfer::srgb_eotf(v) : std::pow(v, r == 1 ? 2.2 : 2.4);
      const int x = label_w + (2 * i + 1) * (f.width - label_w) / (2 * n), y = r * row_h + row_h / 3;
      const StepsOff off = grey_steps_off(f, x, y, std::min(white * rel, t.peak_nits));
      if (off.worst() > worst.worst()) worst = off;
    }
  return make("sdr-shadows/rows", source, worst.worst() <= 1.0,
              fmt::format("worst {:.2f} codes, {:.2f} 16-bit steps off", worst.codes, worst.samples16));
}

}  // namespace hdrd::patterns

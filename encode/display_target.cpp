#include "encode/display_target.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

namespace hdrd {
namespace {

constexpr int kTenBits[] = {10};
constexpr int kSdrBits[] = {8, 10};
constexpr int kHalfBits[] = {16};
constexpr std::string_view kNoAliases[] = {""};
constexpr std::string_view kSdrAliases[] = {"sdr-srgb"};
constexpr std::string_view kBt1886Aliases[] = {"bt1886"};

// REFERENCE.md §1.7 (encoding) and §1.8 (defaults).
const ModeInfo kModes[] = {
    {Mode::hdr10, "hdr10", std::span(kNoAliases, 0), "Rec.2020, PQ (SMPTE ST 2084), 10-bit, ST 2086 + CTA-861.3",
     &color::kRec2020, Transfer::pq, 1000, 0.005, 203.0, kTenBits, true, true, true, true},
    {Mode::hlg, "hlg", std::span(kNoAliases, 0), "Rec.2020, HLG (BT.2100), 10-bit", &color::kRec2020, Transfer::hlg,
     1000, 0, 203.0, kTenBits, true, true, true, true},
    {Mode::scrgb, "scrgb", std::span(kNoAliases, 0), "linear FP16, sRGB primaries, 1.0 = 80 cd/m2, negatives kept",
     &color::kRec709, Transfer::linear, 1000, 0, 203.0, kHalfBits, true, false, false, false},
    {Mode::sdr, "sdr", kSdrAliases, "Rec.709, sRGB piecewise curve (or gamma 2.2) on nits / peak", &color::kRec709,
     Transfer::sdr_curve, 100, 0.1, std::nullopt, kSdrBits, false, false, true, true},
    {Mode::sdr_bt1886, "sdr-bt1886", kBt1886Aliases, "Rec.709, inverse BT.1886 EOTF with Lw = peak, Lb = black",
     &color::kRec709, Transfer::bt1886, 100, 0.1, std::nullopt, kSdrBits, false, false, true, true},
};

constexpr std::string_view kModeNames[] = {"hdr10", "hlg", "scrgb", "sdr", "sdr-bt1886"};

}  // namespace

bool ModeInfo::allows_bits(int b) const { return std::find(bits.begin(), bits.end(), b) != bits.end(); }

std::uint32_t ModeInfo::drm_fourcc(int b) const {
  if (transfer == Transfer::linear) return kDrmFormatAbgr16161616f;
  return b == 8 ? kDrmFormatXrgb8888 : kDrmFormatXbgr2101010;
}

std::span<const ModeInfo> modes() { return kModes; }

const ModeInfo& mode_info(Mode m) {
  for (const auto& i : kModes)
    if (i.mode == m) return i;
  return kModes[0];
}

std::span<const std::string_view> mode_names() { return kModeNames; }

std::string_view to_string(Mode m) { return mode_info(m).name; }

std::optional<Mode> parse_mode(std::string_view s) {
  for (const auto& i : kModes) {
    if (i.name == s) return i.mode;
    for (auto a : i.aliases)
      if (a == s) return i.mode;
  }
  return std::nullopt;
}

std::string fourcc_name(std::uint32_t code) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(i)] = static_cast<char>((code >> (8 * i)) & 0xFF);
  return s;
}

std::string_view to_string(Range r) { return r == Range::full ? "full" : "narrow"; }
std::string_view to_string(SdrCurve c) { return c == SdrCurve::srgb ? "srgb" : "gamma22"; }

std::optional<Range> parse_range(std::string_view s) {
  if (s == "full") return Range::full;
  if (s == "narrow" || s == "limited") return Range::narrow;
  return std::nullopt;
}

std::optional<SdrCurve> parse_sdr_curve(std::string_view s) {
  if (s == "srgb") return SdrCurve::srgb;
  if (s == "gamma22" || s == "gamma2.2") return SdrCurve::gamma22;
  return std::nullopt;
}

MasteringDisplay DisplayTarget::mastering() const {
  MasteringDisplay md;
  if (display_primaries) md.primaries = *display_primaries;
  // ST 2086 describes the display the content was mastered on; hdrd grades every frame in
  // D65 (the working space and every container are D65), so the mastering white is D65 and
  // not a panel's native white (the Hisense fixture's EDID says (0.2822, 0.2969)), whose
  // primaries alone describe the display's gamut.
  md.primaries.white = color::kD65;
  md.max_nits = peak_nits;
  md.min_nits = black_nits;
  return md;
}

H273 h273(const DisplayTarget& t) {
  H273 c;
  c.full_range = t.range == Range::full;
  switch (t.info().transfer) {
    case Transfer::pq: c.primaries = 9, c.transfer = 16; break;
    case Transfer::hlg: c.primaries = 9, c.transfer = 18; break;
    case Transfer::sdr_curve: c.transfer = t.sdr_curve == SdrCurve::srgb ? 13 : 4; break;
    case Transfer::bt1886: c.transfer = 1; break;
    case Transfer::linear: c.transfer = 8; break;  // linear; scRGB has no PNG form
  }
  return c;
}

std::optional<std::string> paper_white_note(const DisplayTarget& t, bool paper_white_asked) {
  const auto& standard = t.info().paper_white_nits;
  if (!paper_white_asked && standard && *standard > t.peak_nits)
    return fmt::format("paper white follows the peak: {} cd/m2, not the {} cd/m2 default above the display peak "
                       "(--paper-white sets it)",
                       t.paper_white_nits, *standard);
  if (t.paper_white_nits > t.peak_nits)
    return fmt::format("paper white {} cd/m2 is above the peak {} cd/m2: diffuse white and everything above it is "
                       "clipped at the peak",
                       t.paper_white_nits, t.peak_nits);
  return std::nullopt;
}

Result<DisplayTarget> resolve_target(Mode mode, const LevelSettings& display, const LevelSettings& request,
                                     std::string_view display_source) {
  const ModeInfo& info = mode_info(mode);
  DisplayTarget t;
  t.mode = mode;
  auto pick = [](const auto& req, const auto& disp, auto fallback) { return req ? *req : disp ? *disp : fallback; };
  t.peak_nits = pick(request.peak_nits, display.peak_nits, info.peak_nits);
  t.black_nits = pick(request.black_nits, display.black_nits, info.black_nits);
  // The coupling rule (REFERENCE.md §1.4, §1.8), in this one place.
  // Paper white follows a peak below it (--peak 150 in hdr10 gives paper white 150, not
  // 203 above the display's white); one that is asked for is kept, and clipped at the peak
  // by every output alike (job::resolve_display warns of both, paper_white_note).
  t.paper_white_nits = pick(request.paper_white_nits, display.paper_white_nits,
                            std::min(info.paper_white_nits.value_or(t.peak_nits), t.peak_nits));
  t.ui_white_nits = pick(request.ui_white_nits, display.ui_white_nits, t.paper_white_nits);
  t.sdr_white_nits = pick(request.sdr_white_nits, display.sdr_white_nits, t.paper_white_nits);
  t.range = pick(request.range, display.range, Range::full);
  t.sdr_curve = pick(request.sdr_curve, display.sdr_curve, SdrCurve::srgb);
  t.sdr_content_eotf = pick(request.sdr_content_eotf, display.sdr_content_eotf, SdrEotf::srgb);
  t.sdr_inverse_tonemap = pick(request.sdr_inverse_tonemap, display.sdr_inverse_tonemap, InverseTonemap::linear);
  t.bits = pick(request.bits, display.bits, info.default_bits());
  t.display_primaries = request.display_primaries ? request.display_primaries : display.display_primaries;
  t.source = display_source.empty() ? "defaults" : std::string(display_source);
  if (request.any_level()) t.source += "+request";
  if (auto ok = validate(t); !ok) return ok.error();
  return t;
}

DisplayTarget default_target(Mode m) {
  auto t = resolve_target(m, {}, {});
  return *t;  // the table's defaults are valid (tests/encode/display_target_test.cpp)
}

Result<void> validate(const DisplayTarget& t) {
  auto bad = [](const char* field, std::string msg) {
    return make_error("display.invalid", std::move(msg), field);
  };
  auto finite_pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (!finite_pos(t.peak_nits) || t.peak_nits > 10000)
    return bad("display.peak_nits", fmt::format("peak {} cd/m2 is not in (0, 10000]", t.peak_nits));
  if (!std::isfinite(t.black_nits) || t.black_nits < 0 || t.black_nits >= t.peak_nits)
    return bad("display.black_nits",
               fmt::format("black {} cd/m2 must be >= 0 and below the peak ({})", t.black_nits, t.peak_nits));
  if (!finite_pos(t.paper_white_nits) || t.paper_white_nits > 10000)
    return bad("display.paper_white_nits",
               fmt::format("paper white {} cd/m2 is not in (0, 10000]", t.paper_white_nits));
  if (!finite_pos(t.ui_white_nits) || t.ui_white_nits > 10000)
    return bad("display.ui_white_nits", fmt::format("UI white {} cd/m2 is not in (0, 10000]", t.ui_white_nits));
  if (!finite_pos(t.sdr_white_nits) || t.sdr_white_nits > 10000)
    return bad("display.sdr_white_nits", fmt::format("SDR white {} cd/m2 is not in (0, 10000]", t.sdr_white_nits));
  const ModeInfo& info = t.info();
  if (!info.allows_bits(t.bits)) {
    std::string allowed;
    for (int b : info.bits) allowed += (allowed.empty() ? "" : " or ") + std::to_string(b);
    return bad("display.bits", fmt::format("{} output is {} bits, not {}", info.name, allowed, t.bits));
  }
  if (t.range == Range::narrow && !info.narrow_range)
    return bad("display.range", fmt::format("{} is a float format and has no narrow range", info.name));
  return {};
}

}  // namespace hdrd

#include "encode/display_target.hpp"

#include <cmath>

#include <fmt/format.h>

namespace hdrd {

std::string_view to_string(Mode m) {
  switch (m) {
    case Mode::hdr10: return "hdr10";
    case Mode::hlg: return "hlg";
    case Mode::scrgb: return "scrgb";
    case Mode::sdr: return "sdr";
    case Mode::sdr_bt1886: return "sdr-bt1886";
  }
  return "?";
}

std::string_view to_string(Range r) { return r == Range::full ? "full" : "narrow"; }
std::string_view to_string(SdrCurve c) { return c == SdrCurve::srgb ? "srgb" : "gamma22"; }

std::optional<Mode> parse_mode(std::string_view s) {
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::scrgb, Mode::sdr, Mode::sdr_bt1886})
    if (to_string(m) == s) return m;
  if (s == "sdr-srgb") return Mode::sdr;
  if (s == "bt1886") return Mode::sdr_bt1886;
  return std::nullopt;
}

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

const color::Primaries& DisplayTarget::container() const {
  return (mode == Mode::hdr10 || mode == Mode::hlg) ? color::kRec2020 : color::kRec709;
}

MasteringDisplay DisplayTarget::mastering() const {
  MasteringDisplay md;
  if (display_primaries) md.primaries = *display_primaries;
  md.max_nits = peak_nits;
  md.min_nits = black_nits;
  return md;
}

DisplayTarget default_target(Mode m) {
  DisplayTarget t;
  t.mode = m;
  switch (m) {
    case Mode::hdr10:
      t.peak_nits = 1000; t.black_nits = 0.005; t.paper_white_nits = 203; t.bits = 10;
      break;
    case Mode::hlg:
      t.peak_nits = 1000; t.black_nits = 0; t.paper_white_nits = 203; t.bits = 10;
      break;
    case Mode::scrgb:
      t.peak_nits = 1000; t.black_nits = 0; t.paper_white_nits = 203; t.bits = 16;
      break;
    case Mode::sdr:
    case Mode::sdr_bt1886:
      t.peak_nits = 100; t.black_nits = 0.1; t.paper_white_nits = 100; t.bits = 8;
      break;
  }
  t.ui_white_nits = t.paper_white_nits;
  t.sdr_white_nits = t.paper_white_nits;
  return t;
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
  const bool sdr = t.mode == Mode::sdr || t.mode == Mode::sdr_bt1886;
  if (sdr && t.bits != 8 && t.bits != 10)
    return bad("display.bits", fmt::format("SDR output is 8 or 10 bits, not {}", t.bits));
  if ((t.mode == Mode::hdr10 || t.mode == Mode::hlg) && t.bits != 10)
    return bad("display.bits", fmt::format("{} output is 10 bits, not {}", to_string(t.mode), t.bits));
  if (t.mode == Mode::scrgb && t.range == Range::narrow)
    return bad("display.range", "scRGB is a float format and has no narrow range");
  return {};
}

}  // namespace hdrd

// Display profile from an EDID. The rules, in the order docs/displays.md lists them:
//  mode   HDR10 when ST 2084 and BT2020RGB are signalled (CTA-861-G §7.5.13, §7.5.5, or a
//         DisplayID 2.0 "BT.2020/SMPTE ST 2084" interface combination), HLG when HLG is
//         signalled without ST 2084, otherwise SDR.
//  peak   desired content max luminance; when missing, CV 0, below 100 or above 10000
//         cd/m2: DisplayID's native max (10 %); else (HDR) the block's max frame-average,
//         the product name's DisplayHDR tier, 400 for a BT.709-class monitor, else 1000;
//         100 (SDR).
//  FALL   desired content max frame-average; when missing: DisplayID full-coverage max,
//         else the peak; never above the peak.
//  black  desired content min luminance (computed from the same block's max, so unusable
//         when that max is); else DisplayID native min; else the mode's default.
//  primaries  base block chromaticities; else DisplayID's; else Rec.709.
#include "display/profile.hpp"

#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "display/edid_json.hpp"

namespace hdrd::display {
namespace {

struct Signals {
  bool pq = false, hlg = false, bt2020_rgb = false, displayid_bt2020_pq = false;
};

Signals signals_of(const EdidInfo& e) {
  Signals s;
  if (e.hdr_static_metadata) {
    s.pq = e.hdr_static_metadata->pq();
    s.hlg = e.hdr_static_metadata->hlg();
  }
  s.bt2020_rgb = e.colorimetry && e.colorimetry->bt2020_rgb();
  s.displayid_bt2020_pq = e.displayid_interface && e.displayid_interface->bt2020_pq();
  return s;
}

void choose_mode(const Signals& s, Profile& p) {
  const bool pq = s.pq || s.displayid_bt2020_pq;
  const bool bt2020 = s.bt2020_rgb || s.displayid_bt2020_pq;
  if (pq && bt2020) {
    p.mode = Mode::hdr10;
    p.mode_reason = s.pq && s.bt2020_rgb ? "SMPTE ST 2084 and BT2020RGB are signalled"
                                         : "DisplayID 2.0 signals the BT.2020/SMPTE ST 2084 combination";
  } else if (s.hlg && !pq) {
    p.mode = Mode::hlg;
    p.mode_reason = "HLG is signalled without SMPTE ST 2084";
    if (!s.bt2020_rgb) p.notes.push_back("HLG is signalled without BT2020RGB colorimetry; BT.2020 is sent anyway");
  } else if (pq) {
    p.mode = Mode::sdr;
    p.mode_reason = "SMPTE ST 2084 is signalled but BT2020RGB colorimetry is not, so HDR10 cannot be sent as RGB";
  } else {
    p.mode = Mode::sdr;
    p.mode_reason = "no HDR transfer function is signalled";
  }
}

bool plausible_peak(double nits) { return std::isfinite(nits) && nits >= kMinPlausibleHdrPeakNits && nits <= kMaxPqNits; }

std::string cv_text(const char* what, std::uint8_t cv, double nits) {
  return fmt::format("{} CV {} ({:.3f} cd/m2)", what, cv, nits);
}

// Returns the block's max luminance when usable, else records why not.
std::optional<double> usable_max(const EdidInfo& e, Profile& p) {
  if (!e.hdr_static_metadata) return std::nullopt;
  const auto& h = *e.hdr_static_metadata;
  if (!h.max_luminance_cv) {
    if (p.is_hdr()) p.notes.push_back("HDR Static Metadata Data Block has no luminance bytes");
    return std::nullopt;
  }
  const double max = *h.max_luminance_cd_m2();
  // CTA-861.3 leaves 0 as "no data" (libdisplay-info reads it so); PQ cannot exceed 10000.
  if (*h.max_luminance_cv == 0 || !plausible_peak(max)) {
    p.notes.push_back(cv_text("desired content max luminance", *h.max_luminance_cv, max) +
                      " is not a plausible display peak: ignored");
    return std::nullopt;
  }
  return max;
}

double gamut_area(const color::Primaries& pr) {
  return std::abs((pr.green.x - pr.red.x) * (pr.blue.y - pr.red.y) - (pr.blue.x - pr.red.x) * (pr.green.y - pr.red.y)) / 2;
}

// The VESA DisplayHDR tier a product name states ("DisplayHDR 600", "HDR400"), if any.
std::optional<int> displayhdr_tier(const std::string& name) {
  std::string n;
  for (char c : name) n += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (std::size_t at = n.find("HDR"); at != std::string::npos; at = n.find("HDR", at + 3)) {
    std::size_t i = at + 3;
    if (i < n.size() && (n[i] == ' ' || n[i] == '-' || n[i] == '_')) ++i;
    int tier = 0, digits = 0;
    while (i < n.size() && std::isdigit(static_cast<unsigned char>(n[i])) && digits < 5) tier = tier * 10 + (n[i++] - '0'), ++digits;
    for (int t : {400, 500, 600, 1000, 1400})
      if (tier == t) return t;
  }
  return std::nullopt;
}

// An HDR display whose block max (and DisplayID) is unusable: the peak the EDID's other
// fields and the panel class imply, most specific first, each said in a note.
void fallback_hdr_peak(const EdidInfo& e, Profile& p) {
  const std::string why = "no usable max luminance";
  if (e.hdr_static_metadata && e.hdr_static_metadata->max_frame_avg_luminance_cv &&
      *e.hdr_static_metadata->max_frame_avg_luminance_cv != 0) {
    const double fall = *e.hdr_static_metadata->max_frame_avg_luminance_cd_m2();
    if (plausible_peak(fall)) {
      p.peak_nits = fall;
      p.notes.push_back(fmt::format("{}: peak {:.1f} cd/m2 from the desired content max frame-average luminance "
                                    "(a display's peak is at least its frame-average)", why, fall));
      return;
    }
  }
  if (const auto tier = displayhdr_tier(p.name)) {
    p.peak_nits = *tier;
    p.notes.push_back(fmt::format("{}: peak {} cd/m2 from the product name's VESA DisplayHDR {} class", why, *tier, *tier));
    return;
  }
  // A desktop monitor (an image width the EDID gives, up to 80 cm: 36 inch at 16:9) whose
  // gamut is BT.709-class (below 1.1 x BT.709's area; the DisplayHDR tiers above 400 need
  // 90 % of DCI-P3) is at best the lowest HDR class, DisplayHDR 400.
  const bool monitor = e.width_cm > 0 && e.width_cm <= kMaxMonitorWidthCm;
  if (monitor && gamut_area(p.primaries) < 1.1 * gamut_area(color::kRec709)) {
    p.peak_nits = kFallbackBt709MonitorPeakNits;
    p.notes.push_back(fmt::format("{}: peak falls back to {:.0f} cd/m2, the VESA DisplayHDR 400 class of a "
                                  "{} cm wide monitor with a BT.709-class gamut", why, kFallbackBt709MonitorPeakNits,
                                  e.width_cm));
    return;
  }
  p.peak_nits = kFallbackHdrPeakNits;
  p.notes.push_back(fmt::format("{}: peak falls back to {:.0f} cd/m2 (hdrd's HDR default; KWin uses 800, gamescope "
                                "1499)", why, kFallbackHdrPeakNits));
}

void choose_peak(const EdidInfo& e, std::optional<double> block_max, Profile& p) {
  if (block_max) {
    p.peak_nits = *block_max;
    return;
  }
  const auto& d = e.displayid_parameters;
  if (d && plausible_peak(d->max_10pct_cd_m2())) {
    p.peak_nits = d->max_10pct_cd_m2();
    p.notes.push_back(fmt::format("peak {:.1f} cd/m2 from DisplayID native max luminance (10% coverage)", p.peak_nits));
  } else if (d && plausible_peak(d->max_full_cd_m2())) {
    p.peak_nits = d->max_full_cd_m2();
    p.notes.push_back(fmt::format("peak {:.1f} cd/m2 from DisplayID native max luminance (full coverage)", p.peak_nits));
  } else if (p.is_hdr()) {
    fallback_hdr_peak(e, p);
  } else {
    p.peak_nits = kFallbackSdrPeakNits;
  }
}

void choose_frame_average(const EdidInfo& e, bool block_usable, Profile& p) {
  std::optional<double> fall;
  if (block_usable && e.hdr_static_metadata) {
    const auto& h = *e.hdr_static_metadata;
    if (h.max_frame_avg_luminance_cv && *h.max_frame_avg_luminance_cv != 0) fall = h.max_frame_avg_luminance_cd_m2();
    else if (h.max_frame_avg_luminance_cv) p.notes.push_back("max frame-average luminance CV 0 (no data): ignored");
  } else if (e.hdr_static_metadata && e.hdr_static_metadata->max_frame_avg_luminance_cv) {
    p.notes.push_back("max frame-average luminance of the block whose max was ignored: ignored too");
  }
  if (!fall && e.displayid_parameters && e.displayid_parameters->max_full_cd_m2() > 0 &&
      std::isfinite(e.displayid_parameters->max_full_cd_m2())) {
    fall = e.displayid_parameters->max_full_cd_m2();
    p.notes.push_back(fmt::format("frame-average {:.1f} cd/m2 from DisplayID native max luminance (full coverage)", *fall));
  }
  if (!fall) {
    p.frame_average_nits = p.peak_nits;
    if (p.is_hdr()) p.notes.push_back("no usable max frame-average luminance: frame-average = peak");
    return;
  }
  if (*fall > p.peak_nits) {
    p.notes.push_back(fmt::format("max frame-average luminance {:.3f} cd/m2 exceeds the peak {:.3f} cd/m2: "
                                  "clamped to the peak", *fall, p.peak_nits));
    fall = p.peak_nits;
  }
  p.frame_average_nits = *fall;
}

void choose_black(const EdidInfo& e, bool block_usable, Profile& p) {
  std::optional<double> black;
  if (e.hdr_static_metadata && e.hdr_static_metadata->min_luminance_cv) {
    const auto& h = *e.hdr_static_metadata;
    if (block_usable || *h.min_luminance_cv == 0) black = h.min_luminance_cd_m2();
    else p.notes.push_back("desired content min luminance depends on the ignored max: ignored");
  }
  if (!black && e.displayid_parameters) {
    const double m = e.displayid_parameters->min_cd_m2();
    if (std::isfinite(m) && m > 0) {
      black = m;
      p.notes.push_back(fmt::format("black {:.4f} cd/m2 from DisplayID native min luminance", m));
    }
  }
  const double fallback = p.is_hdr() ? default_target(p.mode).black_nits : p.peak_nits / 1000.0;
  if (black && *black >= p.peak_nits) {
    p.notes.push_back(fmt::format("min luminance {:.3f} cd/m2 is not below the peak: ignored", *black));
    black.reset();
  }
  p.black_nits = black ? *black : fallback;
}

bool plausible_primaries(const color::Primaries& pr) {
  for (const auto& c : {pr.red, pr.green, pr.blue, pr.white})
    if (!(c.x > 0 && c.y > 0 && c.x + c.y <= 1.0)) return false;
  // A degenerate triangle cannot be a display gamut.
  const double area = (pr.green.x - pr.red.x) * (pr.blue.y - pr.red.y) - (pr.blue.x - pr.red.x) * (pr.green.y - pr.red.y);
  return std::abs(area) > 1e-3;
}

void choose_primaries(const EdidInfo& e, Profile& p) {
  const auto base = e.chromaticity.primaries();
  if (plausible_primaries(base)) {
    p.primaries = base;
  } else if (e.displayid_parameters && plausible_primaries(e.displayid_parameters->primaries)) {
    p.primaries = e.displayid_parameters->primaries;
    p.notes.push_back("base block chromaticities are unusable: primaries from DisplayID");
  } else {
    p.primaries = color::kRec709;
    p.notes.push_back("no usable chromaticities: primaries fall back to Rec.709");
  }
}

}  // namespace

Profile profile_from_edid_info(const EdidInfo& e) {
  Profile p;
  p.name = e.name;
  p.manufacturer = e.manufacturer;
  p.product_code = e.product_code;
  const Signals s = signals_of(e);
  p.signals_pq = s.pq || s.displayid_bt2020_pq;
  p.signals_hlg = s.hlg;
  p.signals_bt2020_rgb = s.bt2020_rgb;
  p.hdr10plus = e.hdr10plus_vsvdb;
  choose_mode(s, p);
  choose_primaries(e, p);  // first: the peak's fallback reads the panel's gamut
  const auto block_max = usable_max(e, p);
  choose_peak(e, block_max, p);
  choose_frame_average(e, block_max.has_value(), p);
  choose_black(e, block_max.has_value(), p);
  p.source = "edid:" + (e.name.empty() ? fmt::format("{}{:04X}", e.manufacturer, e.product_code) : e.name);
  return p;
}

Result<Profile> profile_from_edid(std::span<const std::uint8_t> edid) {
  auto info = parse_edid(edid);
  if (!info) return info.error();
  return profile_from_edid_info(*info);
}

Result<std::vector<std::uint8_t>> read_binary_file(const std::filesystem::path& path, std::size_t max_bytes,
                                                   const io::InputFiles& files) {
  auto bytes = files.read(path, max_bytes);
  if (!bytes) return io::reader_error(bytes.error(), "file.open", "file.open", "path");
  return std::vector<std::uint8_t>(bytes->begin(), bytes->end());
}

Result<Profile> profile_from_edid_file(const std::filesystem::path& path, const io::InputFiles& files) {
  auto bytes = read_binary_file(path, 64 * 1024, files);
  if (!bytes) return bytes.error();
  auto info = parse_edid(*bytes);
  if (!info) {
    Error err = info.error();
    err.message = path.string() + ": " + err.message;
    return err;
  }
  return profile_from_edid_info(*info);
}

LevelSettings profile_levels(const Profile& p) {
  LevelSettings l;
  l.peak_nits = p.peak_nits;
  l.black_nits = p.black_nits;
  l.display_primaries = p.primaries;
  return l;
}

DisplayTarget target_for_profile(const Profile& p) {
  auto t = resolve_target(p.mode, profile_levels(p), {}, p.source);
  if (t) return *t;
  // A profile is validated when it is made (validate_profile); keep the mode's defaults
  // rather than fail if one slipped through.
  return default_target(p.mode);
}

Result<void> validate_profile(const Profile& p) {
  auto bad = [](const char* field, std::string msg) { return make_error("profile.invalid", std::move(msg), field); };
  if (!std::isfinite(p.peak_nits) || p.peak_nits <= 0 || p.peak_nits > kMaxPqNits)
    return bad("peak_nits", fmt::format("peak {} cd/m2 is not in (0, 10000]", p.peak_nits));
  if (!std::isfinite(p.frame_average_nits) || p.frame_average_nits <= 0 || p.frame_average_nits > p.peak_nits)
    return bad("frame_average_nits",
               fmt::format("frame-average {} cd/m2 must be in (0, peak {}]", p.frame_average_nits, p.peak_nits));
  if (!std::isfinite(p.black_nits) || p.black_nits < 0 || p.black_nits >= p.peak_nits)
    return bad("black_nits", fmt::format("black {} cd/m2 must be >= 0 and below the peak {}", p.black_nits, p.peak_nits));
  for (const auto& c : {p.primaries.red, p.primaries.green, p.primaries.blue, p.primaries.white})
    if (!(std::isfinite(c.x) && std::isfinite(c.y) && c.x >= 0 && c.y > 0 && c.x <= 1 && c.y <= 1))
      return bad("primaries", fmt::format("chromaticity ({}, {}) is outside the unit square", c.x, c.y));
  return {};
}

nlohmann::json profile_to_json(const Profile& p) {
  auto xy = [](color::Chromaticity c) { return nlohmann::json::array({c.x, c.y}); };
  return {{"mode", std::string(to_string(p.mode))},
          {"mode_reason", p.mode_reason},
          {"peak_nits", p.peak_nits},
          {"frame_average_nits", p.frame_average_nits},
          {"black_nits", p.black_nits},
          {"primaries",
           {{"red", xy(p.primaries.red)}, {"green", xy(p.primaries.green)}, {"blue", xy(p.primaries.blue)},
            {"white", xy(p.primaries.white)}}},
          {"name", p.name},
          {"manufacturer", p.manufacturer},
          {"product_code", p.product_code},
          {"signals", {{"pq", p.signals_pq}, {"hlg", p.signals_hlg}, {"bt2020_rgb", p.signals_bt2020_rgb},
                       {"hdr10plus", p.hdr10plus}}},
          {"notes", p.notes},
          {"source", p.source}};
}

}  // namespace hdrd::display

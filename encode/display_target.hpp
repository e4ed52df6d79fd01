// What the encoder produces for: the output mode and the display's levels
// (REFERENCE.md §1.4, §1.8, §1.9). Names match the request fields
// display.mode / display.peak_nits / display.black_nits / display.paper_white_nits.
//
// Two tables live here and nowhere else: the output modes (modes(): container, transfer,
// default levels, bits, fourcc, metadata) and the rule that couples the whites to each
// other and to the peak (resolve_target()). Every front end reaches both through them.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "encode/colour/color.hpp"
#include "encode/colour/sdr_content.hpp"
#include "encode/result.hpp"

namespace hdrd {

enum class Mode { hdr10, hlg, scrgb, sdr, sdr_bt1886 };
enum class Range { full, narrow };
enum class SdrCurve { srgb, gamma22 };

// DRM fourcc codes (drm_fourcc.h), repeated here so encode/ needs no libdrm.
inline constexpr std::uint32_t fourcc(char a, char b, char c, char d) {
  return std::uint32_t(a) | (std::uint32_t(b) << 8) | (std::uint32_t(c) << 16) | (std::uint32_t(d) << 24);
}
inline constexpr std::uint32_t kDrmFormatXbgr2101010 = fourcc('X', 'B', '3', '0');
inline constexpr std::uint32_t kDrmFormatAbgr16161616f = fourcc('A', 'B', '4', 'H');
inline constexpr std::uint32_t kDrmFormatXrgb8888 = fourcc('X', 'R', '2', '4');
std::string fourcc_name(std::uint32_t code);  // "XB30", ...

// How a mode's signal is made from display light (REFERENCE.md §1.7).
enum class Transfer { pq, hlg, linear, sdr_curve, bt1886 };

// One output mode: everything a front end, a writer or a test looks up about it.
struct ModeInfo {
  Mode mode;
  std::string_view name;                  // "hdr10" (REFERENCE.md §1.9)
  std::span<const std::string_view> aliases;  // also accepted when parsing ("sdr-srgb")
  std::string_view description;
  const color::Primaries* container;      // the signal's primaries
  Transfer transfer;
  // REFERENCE.md §1.8 defaults; paper white unset means "= peak" (SDR white is the peak).
  double peak_nits, black_nits;
  std::optional<double> paper_white_nits;
  std::span<const int> bits;              // allowed bits per channel; the first is the default
  bool hdr;                               // an HDR signal (PQ, HLG, scRGB)
  bool hdr_metadata;                      // ST 2086 / CTA-861.3 travel with it (hdr10, hlg)
  bool narrow_range;                      // may be sent narrow range (integer codes only)
  bool png;                               // has a PNG form (scRGB, FP16, has not)

  bool sdr() const { return !hdr; }
  int default_bits() const { return bits.front(); }
  bool allows_bits(int b) const;
  std::uint32_t drm_fourcc(int bits_per_channel) const;
};

std::span<const ModeInfo> modes();
const ModeInfo& mode_info(Mode m);
std::string_view to_string(Mode m);
std::optional<Mode> parse_mode(std::string_view s);     // names and aliases
std::span<const std::string_view> mode_names();          // "hdr10", "hlg", ... in table order

std::string_view to_string(Range r);
std::string_view to_string(SdrCurve c);
std::optional<Range> parse_range(std::string_view s);   // "full", "narrow" ("limited")
std::optional<SdrCurve> parse_sdr_curve(std::string_view s);  // "srgb", "gamma22"

// Mastering display colour volume (SMPTE ST 2086).
struct MasteringDisplay {
  color::Primaries primaries = color::kDisplayP3;  // default P3-D65 (REFERENCE.md §6)
  double max_nits = 1000.0;
  double min_nits = 0.005;
};

struct DisplayTarget {
  Mode mode = Mode::hdr10;
  double peak_nits = 1000.0;
  double black_nits = 0.005;
  double paper_white_nits = 203.0;   // luminance of relative 1.0
  double ui_white_nits = 203.0;      // luminance of UI white
  double sdr_white_nits = 203.0;     // where SDR content's white lands in an HDR frame
  // How SDR content placed in the frame (the UI overlay, SDR images) decodes to light:
  // the EOTF of the display it was mastered on (encode/colour/sdr_content.hpp).
  SdrEotf sdr_content_eotf = SdrEotf::srgb;
  // How that light lands in nits (ui.inverse_tonemap): the linear gain to its white, or an
  // inverse tone map bounded by the peak (sdr_light_to_nits).
  InverseTonemap sdr_inverse_tonemap = InverseTonemap::linear;
  Range range = Range::full;
  SdrCurve sdr_curve = SdrCurve::srgb;
  int bits = 10;                     // 10 for hdr10/hlg; 8 or 10 for SDR; 16 (half) for scrgb
  // Primaries of the target display (from EDID when known); their red, green and blue are
  // the ST 2086 mastering primaries, whose white is D65 whatever the panel's (mastering()).
  // The signal container is fixed by the mode.
  std::optional<color::Primaries> display_primaries;
  // Where the levels came from: "defaults", or a display profile's source
  // ("edid:<name>", "+override:<file>"), then "+request" when the request set a level.
  std::string source = "defaults";

  const ModeInfo& info() const { return mode_info(mode); }
  // Container primaries of the encoded signal: Rec.2020 for hdr10/hlg, Rec.709 otherwise.
  const color::Primaries& container() const { return *info().container; }
  bool is_hdr() const { return info().hdr; }
  bool is_sdr() const { return info().sdr(); }
  MasteringDisplay mastering() const;
};

// ITU-T H.273 code points of a target's signal as PNG cICP, AVIF nclx and video carry it.
// SDR: 13 = IEC 61966-2-1 sRGB; 4 = BT.470 System M, "assumed display gamma 2.2"; 1 =
// BT.709, whose reference display EOTF is BT.1886 (H.273 Table 3 note).
struct H273 {
  std::uint8_t primaries = 1, transfer = 13, matrix = 0;  // matrix 0: RGB (identity)
  bool full_range = true;
};
H273 h273(const DisplayTarget& t);

// Levels given by one source (a display profile, a request); unset means "not said".
struct LevelSettings {
  std::optional<double> peak_nits, black_nits, paper_white_nits, ui_white_nits, sdr_white_nits;
  std::optional<Range> range;
  std::optional<SdrCurve> sdr_curve;
  std::optional<SdrEotf> sdr_content_eotf;
  std::optional<InverseTonemap> sdr_inverse_tonemap;
  std::optional<int> bits;
  std::optional<color::Primaries> display_primaries;
  bool any_level() const {
    return peak_nits || black_nits || paper_white_nits || ui_white_nits || sdr_white_nits || range || sdr_curve || sdr_content_eotf || sdr_inverse_tonemap || bits;
  }
};

// The levels resolver (REFERENCE.md §1.4, §1.8): the mode's defaults, then what the display
// says, then what the request says; then the coupling rule, once: paper white unset is the
// mode's (SDR: the peak), UI and SDR white unset follow paper white. `display_source` names
// the display profile ("" when there is none). Validated.
Result<DisplayTarget> resolve_target(Mode mode, const LevelSettings& display, const LevelSettings& request,
                                     std::string_view display_source = "");

// Per-mode defaults (REFERENCE.md §1.8): resolve_target with nothing said.
DisplayTarget default_target(Mode m);
// The one rule for a peak below paper white, said to the user: the default paper white
// follows a lower peak (a note saying so), an asked-for one above the peak is clipped there
// (a note saying so); nullopt otherwise. paper_white_asked: the request or the display
// profile set it.
std::optional<std::string> paper_white_note(const DisplayTarget& t, bool paper_white_asked);

// Checks levels for sanity (finite, positive, black < peak, paper white <= 10000, bits valid
// for the mode). Returns the first problem, naming the field.
Result<void> validate(const DisplayTarget& t);

}  // namespace hdrd

// What the encoder produces for: the output mode and the display's levels
// (REFERENCE.md §1.4, §1.8, §1.9). Names match the request fields
// display.mode / display.peak_nits / display.black_nits / display.paper_white_nits.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "encode/colour/color.hpp"
#include "encode/colour/sdr_content.hpp"
#include "encode/result.hpp"

namespace hdrd {

enum class Mode { hdr10, hlg, scrgb, sdr, sdr_bt1886 };
enum class Range { full, narrow };
enum class SdrCurve { srgb, gamma22 };

std::string_view to_string(Mode m);
std::string_view to_string(Range r);
std::string_view to_string(SdrCurve c);
std::optional<Mode> parse_mode(std::string_view s);     // "hdr10", "hlg", "scrgb", "sdr", "sdr-bt1886"
std::optional<Range> parse_range(std::string_view s);   // "full", "narrow"
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
  Range range = Range::full;
  SdrCurve sdr_curve = SdrCurve::srgb;
  int bits = 10;                     // 10 for hdr10/hlg; 8 or 10 for SDR; 16 (half) for scrgb
  // Primaries of the target display (from EDID when known); used for ST 2086
  // mastering metadata. The signal container is fixed by the mode.
  std::optional<color::Primaries> display_primaries;
  std::string source = "defaults";   // where the levels came from: "defaults", "edid:<name>", "request"

  // Container primaries of the encoded signal: Rec.2020 for hdr10/hlg, Rec.709 otherwise.
  const color::Primaries& container() const;
  bool is_hdr() const { return mode == Mode::hdr10 || mode == Mode::hlg || mode == Mode::scrgb; }
  MasteringDisplay mastering() const;
};

// Per-mode defaults (REFERENCE.md §1.8).
DisplayTarget default_target(Mode m);

// Checks levels for sanity (finite, positive, black < peak, paper white <= 10000, bits valid
// for the mode). Returns the first problem, naming the field.
Result<void> validate(const DisplayTarget& t);

}  // namespace hdrd

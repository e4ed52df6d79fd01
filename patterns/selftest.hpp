// The display-mode suite (docs/display-modes.md): named checks, each citing its source,
// over frames the encoder produced for one display mode. Every check is a function of
// frames and bytes, so a test can feed it a broken frame and see it fail.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/frame.hpp"
#include "encode/io/io.hpp"
#include "encode/tone/tonemap.hpp"

namespace hdrd::patterns {

struct Check {
  std::string name;    // "paper-white/clip", ...
  std::string source;  // "BT.2408: 203 cd/m2 -> PQ 594 full range"
  bool passed = false;
  bool skipped = false;
  std::string detail;  // what was measured against what
};

struct Report {
  std::string mode;  // "hdr10", "sdr", ...
  DisplayTarget target;
  std::vector<Check> checks;
  double seconds = 0;
  bool passed() const;  // no failed check (skipped ones do not fail)
  int failed_count() const;
  nlohmann::json to_json() const;
};

// A display mode (mode_names(): the vocabulary of every --mode; the modes' aliases are
// accepted too) with an optional peak.
Result<DisplayTarget> suite_target(std::string_view mode, std::optional<double> peak_nits);
// "hdr10, hlg, scrgb, sdr, sdr-bt1886": mode_names() as help and errors list them.
std::string suite_modes_text();

// ---- Check functions ----------------------------------------------------------------------
// The frame is a uniform patch of relative 1.0 (paper white) encoded with `curve`: its
// codes must be the standard's code for paper white (PQ 594 for 203 cd/m2 full range,
// HLG 75 %, scRGB paper white / 80, SDR white), within `tolerance_codes`.
Check check_paper_white(const EncodedFrame& frame, const std::string& curve, int tolerance_codes = 1);
// The frame holds Rec.709 red, green and blue (relative 0.5) side by side in thirds: each
// decodes to the BT.709 primary's chromaticity (SDR content not over-saturated in HDR).
Check check_rec709_primaries(const EncodedFrame& frame, const std::string& what);
// No pixel decodes above the display peak (hdr10: no code above the peak's PQ code).
Check check_peak(const EncodedFrame& frame, const std::string& what);
// MaxCLL/MaxFALL decoded from the frame's codes here (CTA-861.3 §A), independent of the
// encoder's own measure_content_light.
ContentLightLevel decode_content_light(const EncodedFrame& frame);
// MaxCLL/MaxFALL in frame.content_light equal the values decoded from the codes here.
Check check_content_light(const EncodedFrame& frame, const std::string& what);
// The HDR_OUTPUT_METADATA blob bytes (CTA-861-G §6.9, struct hdr_output_metadata).
Check check_metadata_blob(const EncodedFrame& frame, std::span<const std::uint8_t> blob);
// The PNG's IHDR and cICP/mDCV/cLLI chunks (PNG 3rd edition, ITU-T H.273).
Check check_png(const EncodedFrame& frame, const io::PngInfo& png);
// The EXR dump's chromaticities, whiteLuminance, attributes and pixel values.
Check check_exr(const EncodedFrame& frame, const io::ExrImage& exr);
// Every registered tone curve is monotonic and within the display maximum for the target.
std::vector<Check> check_curves_monotonic(const DisplayTarget& target);
// A pattern window: the centre decodes to `level_nits` within one code.
Check check_window(const EncodedFrame& frame, double level_nits);
// The frame's display light (the EXR dump, frame.display_nits) equals what a display
// decodes from its codes (patterns/decode.hpp: the mode's EOTF at the target's peak and
// black), every channel within 1 % (near 0: 1 % of the pixel's brightest channel) or half
// the light between its neighbouring codes, whichever is more. For
// saturated colours this is the mode's displayable volume (HLG: the OOTF's reach).
Check check_display_volume(const EncodedFrame& frame, const std::string& what);
// Grey pixels of relative input xs[i] (pixel i, row-major) encoded with `curve`: each within
// one 16-bit PNG step (full range; one code otherwise) of the signal of curve(x) x paper
// white through the mode's inverse EOTF. `kinks` only label the detail.
Check check_tone_kinks(const EncodedFrame& frame, const tonemap::Curve& curve, std::span<const double> xs,
                       const std::string& curve_name, std::span<const double> kinks);
// A black frame's MaxCLL / MaxFALL in its sidecar, PNG cLLI (png may be null: scRGB) and
// HDR_OUTPUT_METADATA blob (empty: none) are all the mastering peak (REFERENCE.md §6).
Check check_black_frame_metadata(const EncodedFrame& frame, const nlohmann::json& sidecar, const io::PngInfo* png,
                                 std::span<const std::uint8_t> blob);
// A UI overlay of 8-bit grey codes `codes8` in equal columns over black: each column decodes
// to ui_white_nits x the target's SDR content EOTF of its code, within one step.
Check check_sdr_content(const EncodedFrame& frame, std::span<const int> codes8, double ui_white_nits);
// The sdr-shadows pattern (patterns.hpp): each row decodes to SDR white x its EOTF.
Check check_sdr_shadows(const EncodedFrame& frame);

// ---- The suite ---------------------------------------------------------------------------
struct SuiteOptions {
  bool render = true;        // render the built-in scenes (skipped cleanly without GL)
  int render_width = 96, render_height = 54;
  // Testing the suite itself: called on every frame right after it is encoded, before any
  // check sees it, so a test can stand in a deliberately broken encoder.
  std::function<void(EncodedFrame&)> tamper;
};
Report run_suite(const DisplayTarget& target, std::string_view mode_name, const SuiteOptions& options = {});

}  // namespace hdrd::patterns

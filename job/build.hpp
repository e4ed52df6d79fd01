// Where the settings are used: a validated request turned into what the libraries take
// (the display target, EncodeSettings, the renderer's request, the pattern's options).
// Every run-time default is decided here, once, for every front end.
#pragma once

#include <string>
#include <vector>

#include "encode/pipeline.hpp"
#include "job/frame_job.hpp"
#include "job/request.hpp"
#include "patterns/patterns.hpp"
#include "shading/renderer.hpp"

namespace hdrd::job {

// The levels resolver (encode/display_target.hpp resolve_target) fed with the display the
// request names (display.connector / display.edid, then display.profile) and the request's
// own levels. A connector that is not attached (headless) keeps the mode's defaults, with a
// warning. Errors from reading an EDID keep their code (edid.*: 422 in the daemon).
// `files`: where display.edid and display.profile are opened (JobOptions::files).
Result<DisplayTarget> resolve_display(const FrameRequest& r, std::vector<std::string>* warnings,
                                      const io::InputFiles& files = {});

// bt2111 exists for hdr10 and hlg: checked once the display has decided the mode.
Result<void> check_pattern_mode(const FrameRequest& r, const DisplayTarget& target);

// Tone curve, exposure settings, gamut, dither, the grade (loaded) and the UI overlay
// (decoded, its declared size checked first). The exposure mode is decided by
// exposure_mode() once the source is known.
// `resources` (a sequence's): loaded on the first call, reused after. `files`: where the
// LUT, the OpenColorIO config and ui.path are opened (JobOptions::files).
Result<EncodeSettings> encode_settings(const FrameRequest& r, const DisplayTarget& target, int threads,
                                       std::vector<std::string>* warnings, LoadedResources* resources = nullptr,
                                       const io::InputFiles& files = {});

// The exposure rule (exposure.mode "auto"): camera when ev100 is given; light-based when
// exposure.illuminance_lux is given; a render: histogram (Unreal's window average, which
// meters what the camera sees: a room seen from inside is exposed for the room even with
// the sun outside its door); EXR input: manual (relative input is already exposed, graded
// footage keeps its levels, absolute input keeps its cd/m2).
exposure::Mode exposure_mode(const FrameRequest& r);

shading::RenderRequest render_request(const FrameRequest& r, const JobOptions& options);
patterns::PatternOptions pattern_options(const FrameRequest& r);
// The pattern library names its own options (--level, --area); the request's are settings.
Error pattern_error(Error e);

}  // namespace hdrd::job

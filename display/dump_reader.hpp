// Reads a raw dump back (OUTBASE.json sidecar + OUTBASE.raw, as io::write_dumps writes
// them) into an EncodedFrame for `hdrd present`. Only these sidecar keys are relied on;
// anything else is ignored, missing optional keys fall back to the mode's defaults:
//   required  mode, width, height, and fourcc ("XB30") or fourcc_code (number)
//   optional  stride_bytes (default width x bytes per pixel), range ("full"),
//             peak_nits, black_nits, paper_white_nits,
//             mastering_display {primaries {red, green, blue, white: [x, y]}, max_nits, min_nits},
//             content_light_level {max_cll_nits[_measured], max_fall_nits[_measured]},
//             files {raw: name relative to the sidecar} (default: the sidecar's name + .raw)
#pragma once

#include <filesystem>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

Result<EncodedFrame> read_dump(const std::filesystem::path& sidecar);

// The sidecar alone (frame.data empty), after checking that the raw file has the size it
// needs: what a sequence reads of every frame before showing the first.
struct DumpHeader {
  EncodedFrame frame;
  std::filesystem::path raw;
};
Result<DumpHeader> read_dump_header(const std::filesystem::path& sidecar);

}  // namespace hdrd::display

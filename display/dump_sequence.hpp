// A sequence of raw dumps for `hdrd present`, as `hdrd render --frames N --format raw`
// writes them (OUTBASE.NNNNN.json + OUTBASE.NNNNN.raw beside the sequence sidecar
// OUTBASE.json). The inputs name the frames as one of:
//   - a printf pattern "out/shot.%05d.json" (or %d): every number that exists, from the
//     lowest, consecutively; a gap is an error naming the missing frame;
//   - a directory: its NAME.json sidecars that have a NAME.raw beside them, in name order;
//   - a list file (.txt, .lst, .list): one sidecar a line, relative to the list's
//     directory; blank lines and '#' comments skipped;
//   - the sequence sidecar OUTBASE.json ("format": "hdrd-sequence"): its
//     files.frames.sidecar pattern, and its fps and content_light_level;
//   - several sidecars, shown in the order given.
// Every frame's header is read before anything is shown: all must have the first one's
// size, fourcc and mode, so a bad frame is an error before the display changes.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

struct DumpSequence {
  std::vector<std::filesystem::path> sidecars;
  std::optional<double> fps;  // from an hdrd-sequence sidecar
  // The sequence's CTA-861.3 levels: the sequence sidecar's, else MaxCLL = the largest
  // frame MaxCLL and MaxFALL = the largest frame average of the frames' sidecars.
  ContentLightLevel content_light;
  int width = 0, height = 0;
  Mode mode = Mode::sdr;
};

// True when the inputs can only mean a sequence (a pattern, a directory, a list, an
// hdrd-sequence sidecar, or more than one file); one plain dump sidecar is a still.
bool names_a_dump_sequence(const std::vector<std::string>& inputs);

// Errors: dump.sequence (what is missing or inconsistent, naming the file), and read_dump's.
Result<DumpSequence> open_dump_sequence(const std::vector<std::string>& inputs);

}  // namespace hdrd::display

// The outputs a frame job can produce: one table (name, file suffix, media type, what the
// encoder must keep for it, which sources and modes it applies to). `formats` in a request
// (--format on the CLI) names them; the daemon's Accept negotiation picks one of the
// replyable ones as the body; dumps write each as OUTBASE<suffix> next to OUTBASE.json.
// A new delivery format is one entry here plus its writer (job/frame_job.cpp).
#pragma once

#include <optional>
#include <string>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "encode/display_target.hpp"
#include "job/settings.hpp"

namespace hdrd::job {

enum class Output { png, exr, raw, scene_exr, heatmap, avif, jxl, jpeg, jpeg_gainmap };

struct OutputInfo {
  Output id;
  std::string_view name;          // as in `formats`: "png", "scene-exr"
  std::string_view suffix;        // appended to OUTBASE: ".png", ".scene.exr"
  std::string_view content_type;  // of the bytes
  std::string_view doc;
  Sources sources;                // which requests can make it
  bool reply;                     // can be the body of a daemon reply (Accept)
  bool in_default_dump;           // part of a dump that names no formats
  bool needs_display_nits;        // the encoder keeps display light (EncodedFrame::display_nits)
  bool needs_signal16;            // the encoder keeps 16-bit PNG samples
  bool needs_scene_frame;         // the renderer's full scene-referred frame
  bool needs_sdr_rendition;       // the SDR rendition of the same frame (the gain map's primary image)
  bool (*for_mode)(Mode);         // null: every mode
};

std::span<const OutputInfo> outputs();
const OutputInfo& output_info(Output o);
const OutputInfo* find_output(std::string_view name);
std::span<const std::string_view> output_names();  // the `formats` choices

// A single file named by its extension (hdrctl -o FILE): each replyable output's suffix,
// plus the other spellings people write (.jpeg, .bin), case-insensitive. ".jpg" names the
// JPEG family (image/jpeg: jpeg in SDR, jpeg-gainmap in hdr10/hlg: the mode decides).
// nullptr for an extension no output is written with.
const OutputInfo* output_for_extension(std::string_view extension);
// Every extension output_for_extension() knows, in table order: ".png", ".exr", ...
std::span<const std::string_view> output_extensions();
// "png, exr, raw, ..." of the outputs that can be a daemon reply (hdrctl's --format).
std::string reply_output_names();
bool applies(const OutputInfo& o, Source source, Mode mode);

// The outputs of a dump that names none: every default one that applies.
std::vector<Output> default_outputs(Source source, Mode mode);
// `formats` as outputs; errors name the setting when one does not apply to the mode or source.
Result<std::vector<Output>> outputs_from_names(const std::vector<std::string>& names, Source source, Mode mode,
                                               std::string_view field_label = "formats");

// ---- the files a name owns --------------------------------------------------------------
// Every file a job named NAME writes is NAME + a suffix (docs/dump-format.md): an output's
// (above), the sidecar's, a sequence's metadata files and its video, and per-frame files
// NAME.%05d + an output's or the sidecar's suffix. Two names own disjoint files unless one
// is the other plus what a suffix holds before one of its dots: "clash.00001" writes
// clash.00001.json, frame 1's sidecar of "clash"; "a.scene" writes a.scene.exr, the
// scene-exr of "a". Such names are refused (colliding_name_ending); a name used again is
// the same owner (the daemon's later job supersedes the earlier one and removes its files).
inline constexpr std::string_view kSidecarSuffix = ".json";
inline constexpr std::string_view kHdr10PlusSuffix = ".hdr10plus.json";
inline constexpr std::string_view kDoviSuffix = ".dovi.json";
inline constexpr std::string_view kFrameNumber = ".%05d";  // printf: a frame's number, 5 digits
// Every suffix but the video's (encode/video/writer.hpp file_extension: no dot within it);
// per-frame ones spelled with kFrameNumber.
std::vector<std::string> owned_suffixes();
// The ending of `name` that could make its files another name's (".00001", ".hdr10plus",
// ".dovi", ".scene", ".heatmap", ...: each suffix's part before one of its inner dots,
// kFrameNumber standing for five digits), or nullopt when there is none.
std::optional<std::string> colliding_name_ending(std::string_view name);

}  // namespace hdrd::job

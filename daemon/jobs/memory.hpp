// What a request will allocate, estimated before it is admitted (docs/performance-daemon.md,
// "Memory", has the table and the measurements behind it). Limits on pixels alone do not
// bound memory: an 8K render with 16 MSAA samples needs gigabytes, a 21 KB PNG may declare
// 128 Mpx, an upload's EXR header says how large its float image will be. The estimate is
// the sum of what the job holds at its peak, per stage, in bytes per pixel:
//   render targets   20 B/px (RGBA32F colour + 32-bit depth), and 20 B/px per MSAA sample
//   readback         16 B/px (scene light, RGBA float)
//   decoded upload   16 B/px (the EXR as RGBA float) plus the upload's own bytes
//   encode           16 B/px (display light when an EXR answer or dump needs it)
//                  +  8 B/px (the encoded frame) + 6 B/px (16-bit PNG samples)
//   reply            the serialised frame, twice (the encoder's buffer and the reply body):
//                    PNG and raw 8 B/px, EXR 16 B/px; a dump writes the same bytes
//   UI overlay       24 B/px of the PNG's declared size (float RGBA and libpng's rows)
//   request text     3x the body (the text, its JSON document, a decoded base64 PNG)
//   scene file       4x a scene_file or glTF's size (parsed, meshes, their GPU copy; its
//                    textures are bounded by the scene loader's own limit)
// plus a fixed 32 MiB per job (shadow map, tables, thread scratch, a first frame's JIT).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "encode/io/beneath.hpp"
#include "encode/io/io.hpp"
#include "encode/result.hpp"
#include "job/outputs.hpp"
#include "job/request.hpp"

namespace hdrd::daemon {

using job::Limits;

// "1.5 GiB", "384 MiB", "12 KiB".
std::string format_bytes(std::uint64_t bytes);

// `reply`: the negotiated body format; unset: a dump (every output written to files).
// `files`: where the job reads its inputs (job::JobOptions::files): the headers the estimate
// reads (the UI PNG's, the first EXR's, a scene file's size) are opened through it, the same
// way the job opens them (encode/io/beneath.hpp), so no estimate reads what the job may not.

// A render (POST /v1/render): its frame, samples, output, scene file and UI. Errors:
// request.limit when the UI PNG declares more pixels than the frame limits allow.
Result<std::uint64_t> estimate_render_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                             std::optional<job::Output> reply,
                                             std::size_t body_bytes, const Limits& limits);

// An upload (POST /v1/encode): the upload's bytes and the EXR's declared size from its
// header. Errors: the EXR's own (exr.not_exr, exr.size, exr.truncated), request.limit for the UI.
Result<std::uint64_t> estimate_encode_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                             std::optional<job::Output> reply,
                                             std::span<const std::uint8_t> exr, const Limits& limits);

// A test pattern (POST /v1/pattern): a display-light frame of the request's size.
std::uint64_t estimate_pattern_memory(const job::FrameRequest& r, std::optional<job::Output> reply,
                                      std::size_t body_bytes);

// A sequence (POST /v1/sequences): one frame's estimate (a render's; an encode's from its
// first EXR's header and file size) for every frame its pipeline holds at once
// (job/sequence.hpp: the frame being rendered/encoded, `queue_depth` queued, the one the
// writer has), plus the video encoder's own memory when the request has a codec: 192 MiB
// + 160 B/px, an envelope over what it was measured to add (maximum resident set of `hdrd
// encode --video` less the same run with --format raw; x265 medium / SVT-AV1 defaults on
// 2 cores): 640x360 +138 / +128 MB, 1080p +519 / +505 MB, 4K +1150 / +1279 MB. And what
// grows with the length: 2 KiB per frame of `frames` (its sidecar entry and light summary,
// kept until the end; issue 28.10 measured ~1 MB per 1000 frames), 0 when the count is not
// known before the first frame (a render whose animation decides).
// Errors: the EXR's own, request.limit for the UI.
Result<std::uint64_t> estimate_sequence_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                               const std::filesystem::path& first_exr,
                                               std::size_t queue_depth, std::size_t body_bytes, const Limits& limits,
                                               int frames = 0);

// The PNG limits a request's UI overlay is read under: no larger than a frame may be.
io::PngLimits ui_png_limits(const Limits& limits);

}  // namespace hdrd::daemon

// From a validated request to a reply: content negotiation (Accept), the request's
// encode settings (grade and UI loaded here), the encoded frame serialised as PNG / EXR /
// raw DRM buffer with its metadata in X-Hdrd-* headers, or dumped into the dump directory.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "daemon/accept.hpp"
#include "daemon/reply.hpp"
#include "daemon/request.hpp"
#include "encode/frame.hpp"
#include "encode/pipeline.hpp"

namespace hdrd::daemon {

// The request's display target once "auto" / an EDID file have been applied (the request's
// explicit fields still override what the display says). display.unavailable when the
// display library is missing or no display is attached.
Result<DisplayTarget> resolve_display(const DisplaySpec& spec, std::vector<std::string>* warnings);

// EncodeSettings for a request: target, tone curve, exposure (the endpoint default when
// the request names no mode), gamut, grade (loaded), UI overlay (decoded).
Result<EncodeSettings> build_encode_settings(const Request& r, const DisplayTarget& target,
                                             exposure::Mode default_exposure, int threads,
                                             std::vector<std::string>* warnings);

// The EXR form of an encoded frame, as write_dumps writes it: display light in the
// container primaries, value x whiteLuminance = cd/m2 (paper white; scrgb: 80).
Result<std::vector<std::uint8_t>> frame_exr_bytes(const EncodedFrame& frame);

// The reply body in the negotiated format, with X-Hdrd-* metadata headers.
Result<Reply> frame_reply(const EncodedFrame& frame, OutputKind kind, const std::vector<std::string>& warnings);

// Writes the dump atomically into `dump_dir` under `name` and answers with the sidecar
// JSON (files included). Only names validated by validate_dump_name() reach this.
Result<Reply> dump_reply(const EncodedFrame& frame, const std::filesystem::path& dump_dir, const std::string& name,
                         const std::vector<std::string>& formats, const std::vector<std::string>& warnings);

// Whether the answer needs the frame's display light (an EXR reply, or a dump with EXR).
bool needs_display_nits(const Request& request, OutputKind kind);

// The answer for an encoded frame: with "dump": true the dump's sidecar (dump_reply),
// else the frame in the negotiated format (frame_reply).
Result<Reply> answer_frame(const EncodedFrame& frame, const Request& request, OutputKind kind,
                           const std::filesystem::path& dump_dir, const std::string& dump_name,
                           const std::vector<std::string>& warnings);

// X-Hdrd-* headers describing a frame (mode, fourcc, size, stride, levels, MaxCLL/MaxFALL).
std::vector<std::pair<std::string, std::string>> frame_headers(const EncodedFrame& frame);

}  // namespace hdrd::daemon

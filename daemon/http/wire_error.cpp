#include "daemon/http/wire_error.hpp"

#include <nlohmann/json.hpp>

namespace hdrd::daemon {
namespace {

struct StatusEntry {
  std::string_view code;  // exact code, or "family." for every code of a family
  unsigned status;
};

// Exact codes first, then families. 4xx: the client's fault (400 the request itself, 422 a
// well-formed request whose content — an uploaded EXR, a named EDID, a curve parameter —
// cannot be used as given); 5xx: the daemon's (or a resource it lacks).
constexpr StatusEntry kStatus[] = {
    {"request.too_large", 413},
    {"request.media_type", 415},
    {"request.not_acceptable", 406},
    {"request.unauthorized", 401},
    {"request.not_found", 404},
    {"request.method", 405},
    {"request.timeout", 504},
    {"request.header_timeout", 408},   // a connection that did not send its request header in time
    {"request.body_timeout", 408},     // ... or its body fast enough
    {"request.length_required", 411},  // chunked request bodies: a body must declare its length
    {"request.cancelled", 499},
    {"path.forbidden", 403},
    // The file model (encode/io/beneath.hpp): a file opened when it is read, beneath the asset
    // root, is a symbolic link, has more than one hard link, or is a FIFO, device, directory.
    {"path.symlink", 403},
    {"path.hard_link", 403},
    {"path.not_regular", 422},
    // Sequence jobs (jobs.hpp): an unknown id, a result asked before it exists, a name a
    // running job writes, files deleted or overwritten since.
    {"job.not_found", 404},
    {"job.not_ready", 409},
    {"job.conflict", 409},
    {"job.gone", 410},
    {"job.file_changed", 410},        // its result or sidecar was replaced (a link, another file)
    {"name.collision", 422},          // a name whose files could be another name's (job/outputs.hpp)
    {"path.not_found", 404},
    {"queue.full", 503},
    {"queue.memory", 503},            // the in-flight memory budget is taken; retry later
    {"server.busy", 503},             // every connection slot holds a request in progress
    {"io.no_space", 507},             // the dump directory's file system is full (RFC 4918 §11.5)
    {"server.draining", 503},
    {"renderer.unavailable", 503},
    {"pipeline.unavailable", 503},
    {"display.unavailable", 503},
    {"gpu.unsupported", 500},
    {"internal", 500},
    {"request.", 400},
    {"path.", 400},
    {"cli.", 400},
    // What the request named or uploaded cannot be used as given.
    {"exr.", 422},
    {"png.", 422},
    {"cube.", 422},
    {"strip.", 422},
    {"tone.", 422},
    {"tonemap.", 422},
    {"exposure.", 422},
    {"grade.", 422},
    {"display.", 422},
    {"edid.", 422},     // a file named by display.edid that is not a valid EDID
    {"profile.", 422},  // ... or one whose display profile is unusable
    {"file.", 422},     // a file named by a request that cannot be read (too large, unreadable)
    {"encode.", 422},
    {"pipeline.", 422},
    {"image.", 422},
    {"ui.", 422},
    {"scene.", 422},
    {"gltf.", 422},
    {"camera.", 422},
    {"environment.", 422},
    {"hdr.", 422},      // a Radiance .hdr environment map that cannot be read (shading/radiance_hdr.cpp), as exr.*
    {"pattern.", 422},
    {"selftest.", 422},
    {"hdr_metadata.", 422},
    {"scanout.", 422},
    // stills: options the frame cannot take (lossless with another depth, JPEG of a non-sRGB frame)
    {"avif.options", 422},
    {"avif.unsupported", 422},
    {"jxl.options", 422},
    {"jxl.unsupported", 422},
    {"jpeg.options", 422},
    {"jpeg.mode", 422},
    {"jpeg.range", 422},
    {"gainmap.", 422},
    // sequences and video: what the request asked that the codec or container cannot do
    {"video.bitstream", 500},
    {"video.mux", 500},
    {"video.encoder", 500},
    {"video.state", 500},
    {"video.libav", 500},  // FFmpeg's libraries missing on the daemon's machine (encode/video/libav.hpp)
    {"video.", 422},
    {"sequence.", 422},
    {"input.", 422},    // an EXR sequence that cannot be read as one (a gap, no match, an empty list)
    {"hdr10plus.", 422},
    {"animation.", 422},   // a scene's animation or keyframes that cannot be sampled
    {"input.", 422},       // a sequence's frames: no file matches, a frame missing, an empty list
    {"plan.", 422},        // a sequence plan file that is not one (the cluster client)
    {"slurm.unknown_job", 404},
    {"cluster.not_found", 404},
    {"cluster.unavailable", 503},  // no Slurm cluster configured ([cluster] slurm_scripts_dir)
    {"slurm.options", 400},
    // The cluster engine's side: Slurm or a subprocess failed, not the request.
    {"slurm.", 502},
    {"process.timeout", 504},
    {"process.", 502},
    // The daemon's own faults and missing resources.
    {"io.", 500},
    {"avif.", 500},
    {"jxl.", 500},
    {"jpeg.", 500},
    {"dump.", 500},
    {"paths.", 500},
    {"deflate.", 500},
    {"frame.", 500},
    {"render.", 500},
    {"gpu.", 500},
    {"gpu_pass.", 500},
    {"config.", 500},
    {"server.", 500},
    {"gl.", 503},
    {"kms.", 503},
    {"present.cancelled", 499},
    {"present.frame_mismatch", 422},  // a sequence frame of another size or mode than the first
    {"present.", 500},
    {"queue.", 503},
    // The client's side of a connection (hdrctl, the tests): never sent by the daemon.
    {"client.", 502},
};

}  // namespace

std::optional<unsigned> status_of(std::string_view code) {
  for (const auto& s : kStatus)
    if (s.code.back() != '.' && code == s.code) return s.status;
  for (const auto& s : kStatus)
    if (s.code.back() == '.' && code.substr(0, s.code.size()) == s.code) return s.status;
  return std::nullopt;
}

unsigned http_status(const Error& e) { return status_of(e.code).value_or(500); }

std::string error_body(const Error& e) {
  // One line whatever the message quotes (the request parser already ensures it; other
  // handlers quote scene names and file errors too).
  nlohmann::json err = {{"code", e.code.empty() ? "internal" : e.code}, {"message", one_line(e.message)}};
  if (!e.field.empty()) err["field"] = e.field;
  // Replace invalid UTF-8 (e.g. from a file name) rather than throw.
  return nlohmann::json{{"error", err}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace hdrd::daemon

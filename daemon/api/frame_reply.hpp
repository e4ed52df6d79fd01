// A finished frame job as an HTTP reply: the negotiated output as the body with the
// frame's metadata in X-Hdrd-* headers, or, for a dump, the files written atomically into
// the dump directory and the sidecar as the body.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "daemon/http/reply.hpp"
#include "job/frame_job.hpp"

namespace hdrd::daemon {

// X-Hdrd-* headers describing a frame: the settings table's headers (mode, levels, tone
// curve: the resolved values), then what only the frame knows (fourcc, size, stride,
// MaxCLL/MaxFALL, mastering, where the levels came from, timings, warnings).
std::vector<std::pair<std::string, std::string>> frame_headers(const job::FrameResult& result);

// The output's bytes move into the reply (the result keeps the rest).
Result<Reply> frame_reply(job::FrameResult& result, job::Output output);

// Only names checked by the request parser (the `name` setting) reach this. A full disk is
// io.no_space (507), naming the directory.
Result<Reply> dump_reply(const job::FrameResult& result, const std::filesystem::path& dump_dir, const std::string& name);

}  // namespace hdrd::daemon

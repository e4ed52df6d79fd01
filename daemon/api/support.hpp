// Small pieces every endpoint handler uses (api.cpp, api_patterns.cpp): replies, the
// request's media type, generated dump names, deadlines and coalescing keys.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/config.hpp"
#include "daemon/http/server.hpp"
#include "daemon/http/reply.hpp"
#include "daemon/jobs/scheduler.hpp"
#include "job/frame_job.hpp"
#include "job/request.hpp"

namespace hdrd::daemon {

double seconds_since(std::chrono::steady_clock::time_point t);

// 200 with pretty-printed JSON (invalid UTF-8 replaced, never thrown over).
Reply json_reply(const nlohmann::json& j);

// The Content-Type's media type, lower case, without parameters ("" when absent).
std::string media_type(const HttpRequest& r);

// A POST whose options are a JSON body: a JSON-ish Content-Type (or none; curl's
// form-urlencoded default too) and no query parameters. The error when it is not.
std::optional<Error> check_json_post(const HttpRequest& r);

// "render-<ms>-<pid>-<id>": the dump name of a request that gave none.
std::string generated_name(std::string_view prefix, std::uint64_t id);

// When the request's time is up: its own timeout_s, at most limits.max_request_seconds,
// counted from its complete arrival.
Clock::time_point request_deadline(const HttpRequest& r, std::optional<double> timeout_s, const Config& cfg);

// Threads each encode job uses: the hardware threads shared among [workers] encode_threads.
int encode_threads_per_job(const Config& c);

// The coalescing key of a canonical request (strings from query parameters may hold
// invalid UTF-8; they are replaced rather than thrown over).
std::string canonical_key(const nlohmann::json& canonical);

// A request as the daemon parses it: its limits, paths confined to the asset root.
job::ParseContext daemon_context(job::Source source, job::Spelling spelling, const Config& cfg);

// The frame job's options in the daemon: its share of the encode threads, and files named
// only by the request (JSON scenes may not reach further files).
job::JobOptions daemon_job_options(const Config& cfg);

}  // namespace hdrd::daemon

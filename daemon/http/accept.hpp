// Content negotiation for frames: which of the replyable outputs (job/outputs.hpp: PNG,
// EXR, raw DRM buffer) answers a request, from its Accept header (RFC 9110 §12.5.1).
// Pure; fuzzed with the request parser.
#pragma once

#include <string>

#include "encode/display_target.hpp"
#include "encode/result.hpp"
#include "job/outputs.hpp"

namespace hdrd::daemon {

// q-values honoured, q=0 refuses, the most specific range wins; ties go to the table's
// order (the mode's natural image format first). Without Accept (or */*): PNG, or EXR for
// scrgb, which has no PNG form. Error request.not_acceptable (406).
Result<job::Output> negotiate_output(const std::string* accept, Mode mode, job::Source source = job::Source::render);

// A dump answers its sidecar: Accept must allow application/json.
Result<void> accepts_json(const std::string* accept);

}  // namespace hdrd::daemon

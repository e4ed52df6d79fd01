// Content negotiation for frames: which of PNG, EXR, raw DRM buffer (or the dump's JSON)
// answers a request, from its Accept header (RFC 9110 §12.5.1). Pure; fuzzed with the
// request parser.
#pragma once

#include <string>
#include <string_view>

#include "encode/display_target.hpp"
#include "encode/result.hpp"

namespace hdrd::daemon {

enum class OutputKind { png, exr, raw, json_dump };
std::string_view content_type(OutputKind k);

// q-values honoured, q=0 refuses, the most specific range wins. Without Accept (or */*):
// PNG, or EXR for scrgb, which has no PNG form; with "dump": true the answer is always
// JSON. Error request.not_acceptable (406).
Result<OutputKind> negotiate_output(const std::string* accept, Mode mode, bool dump);

}  // namespace hdrd::daemon

// Log lines are text for people and for line-oriented tools, and much of what they carry
// comes from clients: request targets, methods, job names, scene keys inside error
// messages. A CR or LF in such a field forges a log line; an ESC drives the terminal that
// shows the log (CVE-2003-0020 is the classic). So every message the daemon logs passes
// one escaper before it is written (the formatter below, installed for the whole
// process): the log never holds a control byte or ill-formed UTF-8, and the escaping is
// unambiguous, so unescape_log_text gives back the exact bytes that were logged.
//
// Escaped: the backslash itself (\\), LF, CR and TAB (\n \r \t), every other C0 byte and
// DEL (\xHH), the C1 controls U+0080..U+009F (8-bit CSI is an escape sequence to some
// terminals), the Unicode line and paragraph separators and the bidirectional
// embedding/override/isolate controls (they reorder what a reader sees: "Trojan Source",
// CVE-2021-42574), each byte of their UTF-8 as \xHH, and every byte that is not part of
// well-formed UTF-8 (RFC 3629 §3) as \xHH. Everything else is copied as it is.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace hdrd::daemon {

std::string escape_log_text(std::string_view text);

// The inverse: the bytes escape_log_text was given, or nullopt when `escaped` is not
// something it can produce (a lone backslash, an unknown escape, a raw control byte).
std::optional<std::string> unescape_log_text(std::string_view escaped);

// Makes every spdlog logger of the process format with `pattern` (spdlog's pattern
// syntax) and pass each message through escape_log_text first.
void set_escaped_log_pattern(const std::string& pattern);

}  // namespace hdrd::daemon

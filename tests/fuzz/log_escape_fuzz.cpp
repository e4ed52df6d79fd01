// Fuzz target: the log escaper (daemon/log_escape.hpp) on any bytes. Asserts that the
// escaped text holds no control byte and is well-formed UTF-8, that it decodes back to the
// input exactly (so no two inputs log alike), and that any text the decoder accepts
// re-escapes to something that decodes to the same bytes.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "daemon/log_escape.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

// RFC 3629 §4, written out separately from the escaper's own decoder.
bool well_formed_utf8(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto u = [&](std::size_t k) { return i + k < s.size() ? static_cast<unsigned char>(s[i + k]) : 0x100u; };
    const unsigned c = u(0);
    const auto cont = [&](std::size_t k, unsigned lo = 0x80, unsigned hi = 0xbf) { return u(k) >= lo && u(k) <= hi; };
    if (c < 0x80) i += 1;
    else if (c >= 0xc2 && c <= 0xdf && cont(1)) i += 2;
    else if (c == 0xe0 && cont(1, 0xa0) && cont(2)) i += 3;
    else if (((c >= 0xe1 && c <= 0xec) || c == 0xee || c == 0xef) && cont(1) && cont(2)) i += 3;
    else if (c == 0xed && cont(1, 0x80, 0x9f) && cont(2)) i += 3;
    else if (c == 0xf0 && cont(1, 0x90) && cont(2) && cont(3)) i += 4;
    else if (c >= 0xf1 && c <= 0xf3 && cont(1) && cont(2) && cont(3)) i += 4;
    else if (c == 0xf4 && cont(1, 0x80, 0x8f) && cont(2) && cont(3)) i += 4;
    else return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string in(reinterpret_cast<const char*>(data), size);
  const std::string out = hdrd::daemon::escape_log_text(in);
  for (unsigned char c : out) check(c >= 0x20 && c != 0x7f);
  check(well_formed_utf8(out));
  const auto back = hdrd::daemon::unescape_log_text(out);
  check(back && *back == in);
  if (const auto decoded = hdrd::daemon::unescape_log_text(in)) {
    const auto again = hdrd::daemon::unescape_log_text(hdrd::daemon::escape_log_text(*decoded));
    check(again && *again == *decoded);
  }
  return 0;
}

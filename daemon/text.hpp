// Error messages are one human line (docs/api.md "Errors"), even when they quote what a
// request sent: a JSON key may hold "\n", a path or query parameter %0A.
#pragma once

#include <string>
#include <string_view>

namespace hdrd::daemon {

// `s` with every control character (C0 and DEL) replaced by a space.
inline std::string one_line(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return out;
}

}  // namespace hdrd::daemon

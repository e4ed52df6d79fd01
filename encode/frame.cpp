#include "encode/frame.hpp"

namespace hdrd {

std::string fourcc_name(std::uint32_t code) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(i)] = static_cast<char>((code >> (8 * i)) & 0xFF);
  return s;
}

}  // namespace hdrd

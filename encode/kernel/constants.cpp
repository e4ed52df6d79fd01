#include "encode/kernel/constants.hpp"

#include <fmt/format.h>

namespace hdrd::kernel {

std::string glsl_constants() {
  // {:.9e}: nine significant digits round-trip a float exactly.
  return fmt::format(
      "const vec3 kLuma = vec3({:.9e}, {:.9e}, {:.9e});\n"
      "const float kInvScrgbUnitNits = {:.9e};\n"
      "const float kMax16 = {:.9e};\n"
      "const float kCode10To16 = {:.9e};\n",
      kLumaR, kLumaG, kLumaB, kInvScrgbUnitNits, kMax16, kCode10To16);
}

}  // namespace hdrd::kernel

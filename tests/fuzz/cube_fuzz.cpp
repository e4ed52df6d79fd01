// Fuzz target for the .cube parser (encode/grade/lut.cpp). Beyond "no crash": whatever parses
// must write back and re-parse to the same tables, and evaluate without reading outside the tables.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "encode/grade/lut.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hdrd::lut;
  auto parsed = parse_cube(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz");
  if (!parsed.ok()) {
    if (parsed.error().message.rfind("fuzz:", 0) != 0) std::abort();  // every error names its line
    return 0;
  }
  const CubeFile& cube = *parsed;
  if (auto text = format_cube(cube); text.ok()) {
    auto again = parse_cube(*text, "again");
    if (!again.ok() || !(*again == cube)) std::abort();
  }
  // Evaluation must not read outside the tables (ASan watches); extreme table values may
  // overflow to inf, so the results themselves are not checked.
  const Rgb probes[] = {{0, 0, 0}, {1, 1, 1}, {0.3f, 0.6f, 0.9f}, {-1, 2, 0.5f}, {NAN, 0, 0}, {INFINITY, -INFINITY, 1e30f}};
  volatile float sink = 0;
  for (const auto interp : {Interpolation::tetrahedral, Interpolation::trilinear})
    for (const auto& p : probes) sink = sink + eval(cube, p, interp)[0];
  if (cube.lut3d && cube.lut3d->size <= 64) {
    float px[4 * 5] = {0, 0, 0, 1, 1, 1, 1, 1, 0.3f, 0.6f, 0.9f, 1, -1, 2, 0.5f, 1, NAN, 0, 0, 1};
    Applier3D(*cube.lut3d, Interpolation::tetrahedral).apply(px, 5);
  }
  return 0;
}

// Fuzz target: the JSON scene parser and scene validation (shading/scene_json.cpp),
// as the daemon runs them on inline scenes: no file references, the default limits
// lowered so that a valid input cannot make the fuzzer spend seconds building meshes.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shading/animation.hpp"
#include "shading/scene_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hdrd::shading::SceneLoadOptions options;
  options.allow_files = false;
  options.limits.max_triangles = 200'000;
  options.limits.max_instances = 2'000;
  auto scene = hdrd::shading::parse_scene_json_text(std::string_view(reinterpret_cast<const char*>(data), size), options);
  // Animations are posed at their start, middle, end and beyond (clamping).
  if (scene && scene->animation) {
    const double end = scene->animation->duration_s();
    for (double t : {-1.0, 0.0, end * 0.37, end, end + 1e6}) (void)hdrd::shading::animate(*scene, *scene->animation, t);
  }
  return 0;
}

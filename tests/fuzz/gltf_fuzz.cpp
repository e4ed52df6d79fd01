// Fuzz target: glTF 2.0 from memory (tinygltf LoadBinaryFromMemory / LoadASCIIFromString
// and hdrd's conversion in shading/gltf_loader.cpp), with no file access, as a daemon
// upload would be loaded.
#include <cstddef>
#include <cstdint>
#include <span>

#include "shading/animation.hpp"
#include "shading/scene_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hdrd::shading::SceneLoadOptions options;
  options.allow_files = false;
  options.limits.max_triangles = 2'000'000;
  auto scene = hdrd::shading::load_gltf_memory(std::span<const std::uint8_t>(data, size), "", options);
  // Animations are posed at their start, middle, end and beyond (clamping).
  if (scene && scene->animation) {
    const double end = scene->animation->duration_s();
    for (double t : {-1.0, 0.0, end * 0.37, end, end + 1e6}) (void)hdrd::shading::animate(*scene, *scene->animation, t);
  }
  return 0;
}

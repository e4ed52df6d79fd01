// Fuzz target: glTF 2.0 from memory (tinygltf LoadBinaryFromMemory / LoadASCIIFromString
// and hdrd's conversion in shading/gltf_loader.cpp), with no file access, as a daemon
// upload would be loaded.
#include <cstddef>
#include <cstdint>
#include <span>

#include "shading/scene_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hdrd::shading::SceneLoadOptions options;
  options.allow_files = false;
  options.limits.max_triangles = 2'000'000;
  auto scene = hdrd::shading::load_gltf_memory(std::span<const std::uint8_t>(data, size), "", options);
  (void)scene;
  return 0;
}

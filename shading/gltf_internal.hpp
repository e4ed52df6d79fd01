// glTF loading without the default rig or validation, for JSON scenes that import a
// glTF file and bring their own lights.
#pragma once

#include <filesystem>

#include "shading/scene_loader.hpp"

namespace hdrd::shading {

// The file's meshes, materials, textures, instances, KHR_lights_punctual lights (world
// space) and the first camera in the node tree, if any.
Result<Scene> load_gltf_raw(const std::filesystem::path& path, const SceneLoadOptions& options);

}  // namespace hdrd::shading

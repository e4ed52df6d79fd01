// Where scenes come from: built-in scenes by name, hdrd JSON scene documents
// (docs/scene-format.md), glTF 2.0 files (.gltf/.glb) through tinygltf.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"
#include "shading/scene.hpp"

namespace hdrd::shading {

// 100/pi cd/m2: the luminance of a white diffuser under the default rig's 100 lux key light,
// which light-based exposure maps to paper white (the settings table's default; a test keeps
// them equal).
inline constexpr double kGltfEmissiveNits = 31.830988618379067;

struct SceneLoadOptions {
  std::filesystem::path base_dir = ".";  // relative paths in JSON scenes resolve against this
  // false: a scene may not reach other files on its own: JSON scenes may not import glTF
  // files, and a glTF file may read its buffers and images only from its own directory
  // (no absolute paths, no ".."). The scene path given to load_scene is always read.
  bool allow_files = true;
  // Where every file a scene reads is opened, at the moment it is read (the scene itself, a
  // glTF's buffers and images, an environment map): beneath the daemon's asset root, or as
  // given (encode/io/beneath.hpp).
  io::InputFiles files;
  SceneLimits limits;
  // Luminance of a glTF emissive value of 1.0 (emissiveFactor x emissive_strength x
  // texture). glTF itself does not fix the unit; the request's gltf_emissive_nits (the
  // settings table, default kGltfEmissiveNits) sets it.
  double gltf_emissive_nits = kGltfEmissiveNits;
  // A glTF file without lights gets a default rig (100 lux key light, 10 cd/m2 ambient);
  // false when an environment lights it (RenderRequest::environment): then it gets
  // exactly its own lights.
  bool default_rig = true;
};

// ---- Built-in scenes ---------------------------------------------------------------------
std::string default_scene_name();  // "material-grid"
std::vector<std::string> builtin_scene_names();
bool is_builtin_scene(std::string_view name);
Result<Scene> make_builtin_scene(std::string_view name);
// The built-in scenes are still except "hdr": its camera walks from the dark interior
// (t = 0) out through the door into the sunlit yard, arriving at this time.
inline constexpr double kHdrWalkOutSeconds = 6.0;

// ---- JSON scenes ---------------------------------------------------------------------------
inline constexpr std::size_t kMaxSceneJsonBytes = 256u << 20;  // a scene file or text, at most
// Strict: unknown fields, wrong types, non-finite numbers and absurd counts are errors
// naming the field ("lights[2].illuminance_lux: ...").
Result<Scene> parse_scene_json(const nlohmann::json& doc, const SceneLoadOptions& options = {});
Result<Scene> parse_scene_json_text(std::string_view text, const SceneLoadOptions& options = {});

// ---- glTF 2.0 --------------------------------------------------------------------------------
// Metallic-roughness materials, sRGB base colour and emissive textures, normal maps,
// KHR_materials_emissive_strength, KHR_lights_punctual, cameras. A file without lights gets
// a default rig (with a warning saying so) unless options.default_rig is false; otherwise
// exactly its own lights.
Result<Scene> load_gltf_file(const std::filesystem::path& path, const SceneLoadOptions& options = {});
Result<Scene> load_gltf_memory(std::span<const std::uint8_t> bytes, const std::filesystem::path& base_dir,
                               const SceneLoadOptions& options = {});

// Any of the above: a built-in name, a .gltf/.glb/.json path (relative to base_dir).
Result<Scene> load_scene(std::string_view name_or_path, const SceneLoadOptions& options = {});

}  // namespace hdrd::shading

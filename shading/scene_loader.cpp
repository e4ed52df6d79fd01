#include "shading/scene_loader.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace hdrd::shading {
namespace {

bool has_extension(const std::filesystem::path& p, std::string_view ext) {
  std::string e = p.extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ext;
}

Result<Scene> load_json_file(const std::filesystem::path& path, const SceneLoadOptions& options) {
  auto text = options.files.read(path, kMaxSceneJsonBytes);
  if (!text && text.error().code == "file.too_large")
    return make_error("scene.file", fmt::format("'{}' is larger than 256 MiB", path.string()), "scene");
  if (!text) return io::reader_error(text.error(), "scene.file", "scene.file", "scene");
  SceneLoadOptions o = options;
  o.base_dir = path.parent_path();  // the file's own references resolve next to it
  auto s = parse_scene_json_text(*text, o);
  if (!s) return make_error(s.error().code, fmt::format("{}: {}", path.filename().string(), s.error().message),
                            s.error().field);
  if (s->name == "json") s->name = path.stem().string();
  return s;
}

}  // namespace

Result<Scene> load_scene(std::string_view name_or_path, const SceneLoadOptions& options) {
  if (is_builtin_scene(name_or_path)) return make_builtin_scene(name_or_path);
  const std::filesystem::path given(name_or_path);
  const bool known_ext = has_extension(given, ".gltf") || has_extension(given, ".glb") || has_extension(given, ".json");
  if (!known_ext)
    return make_error("scene.unknown",
                      fmt::format("unknown scene '{}': not a built-in scene ({}) nor a .gltf/.glb/.json file",
                                  name_or_path, fmt::join(builtin_scene_names(), ", ")),
                      "scene");
  const std::filesystem::path path = given.is_absolute() ? given : options.base_dir / given;
  std::error_code ec;  // for the message only: the file is opened when it is read (options.files)
  if (!std::filesystem::exists(std::filesystem::symlink_status(path, ec)) && !std::filesystem::exists(path, ec))
    return make_error("scene.file", fmt::format("scene file '{}' does not exist", path.string()), "scene");
  if (has_extension(path, ".json")) return load_json_file(path, options);
  return load_gltf_file(path, options);
}

}  // namespace hdrd::shading

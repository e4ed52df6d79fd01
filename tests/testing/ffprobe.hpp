// ffprobe, the third-party reader the video tests check hdrd's files with: whether it is
// installed, its JSON of a file's streams and frames, and the side data in an entry.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/testing/testing.hpp"

namespace hdrd::testing {

// True when `tool -version` runs (ffprobe, ffmpeg).
inline bool have_tool(const std::string& tool) { return run_command(tool + " -version").exit_code == 0; }
inline bool have_ffprobe() { return have_tool("ffprobe"); }

// `ffprobe -show_streams -show_frames -of json FILE`, or nullopt when it fails.
inline std::optional<nlohmann::json> ffprobe(const std::filesystem::path& file) {
  const auto r = run_command("ffprobe -v error -show_streams -show_frames -of json '" + file.string() + "'");
  if (r.exit_code != 0) return std::nullopt;
  return nlohmann::json::parse(r.out, nullptr, false);
}

// The side data of a stream or frame entry by its side_data_type ("Mastering display
// metadata", "Content light level metadata", ...), or null.
inline const nlohmann::json* side_data(const nlohmann::json& entry, const std::string& type) {
  if (!entry.contains("side_data_list")) return nullptr;
  for (const auto& s : entry["side_data_list"])
    if (s.value("side_data_type", "") == type) return &s;
  return nullptr;
}

}  // namespace hdrd::testing

#include "job/outputs.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace hdrd::job {
namespace {

bool has_png(Mode m) { return mode_info(m).png; }

const OutputInfo kOutputs[] = {
    {Output::png, "png", ".png", "image/png",
     "16-bit RGB with cICP/mDCV/cLLI (HDR, 10-bit SDR), 8-bit RGB (8-bit SDR)", kAllSources, true, true, false, true,
     false, &has_png},
    {Output::exr, "exr", ".exr", "image/x-exr", "display-referred linear light, half float, container primaries",
     kAllSources, true, true, true, false, false, nullptr},
    {Output::raw, "raw", ".raw", "application/octet-stream", "the DRM scan-out buffer (the sidecar says its format)",
     kAllSources, true, true, false, false, false, nullptr},
    {Output::scene_exr, "scene-exr", ".scene.exr", "image/x-exr",
     "a render's scene-referred light: float32, linear Rec.709, absolute cd/m2", kRender, false, true, false, false,
     true, nullptr},
    {Output::heatmap, "heatmap", ".heatmap.png", "image/png",
     "false colour of the display cd/m2 decoded from the codes, with a legend", kAllSources, false, false, false, false,
     false, nullptr},
};

constexpr std::string_view kNames[] = {"png", "exr", "raw", "scene-exr", "heatmap"};

}  // namespace

std::span<const OutputInfo> outputs() { return kOutputs; }

const OutputInfo& output_info(Output o) {
  for (const auto& i : kOutputs)
    if (i.id == o) return i;
  return kOutputs[0];
}

const OutputInfo* find_output(std::string_view name) {
  for (const auto& i : kOutputs)
    if (i.name == name) return &i;
  return nullptr;
}

std::span<const std::string_view> output_names() { return kNames; }

bool applies(const OutputInfo& o, Source source, Mode mode) {
  return job::applies(o.sources, source) && (!o.for_mode || o.for_mode(mode));
}

std::vector<Output> default_outputs(Source source, Mode mode) {
  std::vector<Output> out;
  for (const auto& o : kOutputs)
    if (o.in_default_dump && applies(o, source, mode)) out.push_back(o.id);
  return out;
}

Result<std::vector<Output>> outputs_from_names(const std::vector<std::string>& names, Source source, Mode mode,
                                               std::string_view field_label) {
  if (names.empty()) return default_outputs(source, mode);
  std::vector<Output> out;
  for (const auto& n : names) {
    const OutputInfo* o = find_output(n);
    if (!o) return make_error("request.value", fmt::format("{}: unknown format '{}'", field_label, n), "formats");
    if (!job::applies(o->sources, source))
      return make_error("request.value", fmt::format("{}: {} is not made by {} requests", field_label, n, to_string(source)),
                        "formats");
    if (o->for_mode && !o->for_mode(mode))
      return make_error("request.value", fmt::format("{}: {} has no {} form", field_label, to_string(mode), n), "formats");
    if (std::find(out.begin(), out.end(), o->id) == out.end()) out.push_back(o->id);
  }
  return out;
}

}  // namespace hdrd::job

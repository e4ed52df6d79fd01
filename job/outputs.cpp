#include "job/outputs.hpp"

#include <algorithm>
#include <cctype>

#include <fmt/format.h>

namespace hdrd::job {
namespace {

bool has_png(Mode m) { return mode_info(m).png; }
bool is_sdr_srgb(Mode m) { return m == Mode::sdr; }
bool has_gain_map(Mode m) { return m == Mode::hdr10 || m == Mode::hlg; }

const OutputInfo kOutputs[] = {
    {Output::png, "png", ".png", "image/png",
     "16-bit RGB with cICP/mDCV/cLLI (HDR, 10-bit SDR), 8-bit RGB (8-bit SDR)", kAllSources, true, true, false, true,
     false, false, &has_png},
    {Output::exr, "exr", ".exr", "image/x-exr", "display-referred linear light, half float, container primaries",
     kAllSources, true, true, true, false, false, false, nullptr},
    {Output::raw, "raw", ".raw", "application/octet-stream", "the DRM scan-out buffer (the sidecar says its format)",
     kAllSources, true, true, false, false, false, false, nullptr},
    {Output::scene_exr, "scene-exr", ".scene.exr", "image/x-exr",
     "a render's scene-referred light: float32, linear Rec.709, absolute cd/m2", kRender, false, true, false, false,
     true, false, nullptr},
    {Output::heatmap, "heatmap", ".heatmap.png", "image/png",
     "false colour of the display cd/m2 decoded from the codes, with a legend", kAllSources, false, false, false, false,
     false, false, nullptr},
    {Output::avif, "avif", ".avif", "image/avif",
     "AVIF (AV1, libaom): 8/10/12-bit, lossless or lossy, colr nclx + clli/mdcv (docs/dump-format.md)", kAllSources,
     true, false, false, true, false, false, &has_png},
    {Output::jxl, "jxl", ".jxl", "image/jxl", "JPEG XL (libjxl): PQ/HLG/SDR colour encoding, intensity_target = peak",
     kAllSources, true, false, false, true, false, false, &has_png},
    {Output::jpeg, "jpeg", ".jpg", "image/jpeg", "8-bit sRGB JPEG of an SDR frame (sdr mode, srgb, full range)",
     kAllSources, true, false, false, false, false, false, &is_sdr_srgb},
    {Output::jpeg_gainmap, "jpeg-gainmap", ".jpg", "image/jpeg",
     "SDR JPEG + gain map to the HDR frame (ISO 21496-1, Ultra HDR XMP, MPF); hdr10 and hlg", kSceneReferred, true,
     false, false, false, true, true, &has_gain_map},
};

// Extensions that are not an output's suffix but name one: the output whose suffix they spell.
struct ExtensionAlias {
  std::string_view extension, suffix;
};
constexpr ExtensionAlias kExtensionAliases[] = {{".jpeg", ".jpg"}, {".bin", ".raw"}};

std::vector<std::string_view> make_names() {
  std::vector<std::string_view> v;
  for (const auto& o : kOutputs) v.push_back(o.name);
  return v;
}

std::vector<std::string_view> make_extensions() {
  std::vector<std::string_view> v;
  for (const auto& o : kOutputs)
    if (o.reply && std::find(v.begin(), v.end(), o.suffix) == v.end()) v.push_back(o.suffix);
  for (const auto& a : kExtensionAliases) v.push_back(a.extension);
  return v;
}

bool iequal(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

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

std::span<const std::string_view> output_names() {
  static const std::vector<std::string_view> names = make_names();
  return names;
}

const OutputInfo* output_for_extension(std::string_view extension) {
  std::string_view suffix = extension;
  for (const auto& a : kExtensionAliases)
    if (iequal(extension, a.extension)) suffix = a.suffix;
  for (const auto& o : kOutputs)
    if (o.reply && iequal(o.suffix, suffix)) return &o;
  return nullptr;
}

std::span<const std::string_view> output_extensions() {
  static const std::vector<std::string_view> extensions = make_extensions();
  return extensions;
}

std::string reply_output_names() {
  std::string s;
  for (const auto& o : kOutputs)
    if (o.reply) s += (s.empty() ? "" : ", ") + std::string(o.name);
  return s;
}

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

std::vector<std::string> owned_suffixes() {
  std::vector<std::string> out = {std::string(kSidecarSuffix), std::string(kHdr10PlusSuffix), std::string(kDoviSuffix)};
  std::vector<std::string> per_frame = {std::string(kSidecarSuffix)};
  for (const auto& o : kOutputs) per_frame.emplace_back(o.suffix);
  for (const auto& s : per_frame) {
    if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(s);
    out.push_back(std::string(kFrameNumber) + s);
  }
  return out;
}

namespace {

// How many characters of `name`'s end match `ending`, where kFrameNumber in it stands for a
// dot and five digits; 0 when they do not.
std::size_t ends_with_pattern(std::string_view name, std::string_view ending) {
  std::string want;
  for (std::size_t i = 0; i < ending.size();)
    if (ending.substr(i, kFrameNumber.size()) == kFrameNumber) want += ".#####", i += kFrameNumber.size();
    else want += ending[i++];
  if (name.size() < want.size()) return 0;
  const std::string_view tail = name.substr(name.size() - want.size());
  for (std::size_t i = 0; i < want.size(); ++i)
    if (want[i] == '#' ? !std::isdigit(static_cast<unsigned char>(tail[i])) : tail[i] != want[i]) return 0;
  return want.size();
}

}  // namespace

std::optional<std::string> colliding_name_ending(std::string_view name) {
  for (const auto& suffix : owned_suffixes())
    for (std::size_t dot = suffix.find('.', 1); dot != std::string::npos; dot = suffix.find('.', dot + 1)) {
      const std::string ending = suffix.substr(0, dot);  // what NAME + it + the rest would share
      if (const std::size_t n = ends_with_pattern(name, ending); n > 0) return std::string(name.substr(name.size() - n));
    }
  return std::nullopt;
}

}  // namespace hdrd::job

#include "display/dump_sequence.hpp"

#include <algorithm>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/dump_reader.hpp"
#include "encode/io/file_sequence.hpp"

namespace hdrd::display {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxFrames = 1'000'000;

Error sequence_error(std::string message) { return make_error("dump.sequence", std::move(message), "input"); }

// Raw dumps: a sidecar with its .raw beside it (io::file_sequence: patterns, directories, lists).
io::FileSequenceRules dump_rules() {
  io::FileSequenceRules r;
  r.code = "dump.sequence";
  r.field = "input";
  r.extension = ".json";
  r.what = "raw dump (NAME.json + NAME.raw)";
  r.max_files = kMaxFrames;
  r.accept = [](const fs::path& p) {
    fs::path raw = p;
    raw.replace_extension(".raw");
    std::error_code ec;
    return fs::is_regular_file(raw, ec);
  };
  return r;
}

// An hdrd-sequence sidecar (job/sequence: "format": "hdrd-sequence"), or nullopt.
std::optional<json> sequence_sidecar(const fs::path& p) {
  if (p.extension() != ".json") return std::nullopt;
  std::error_code ec;
  if (fs::file_size(p, ec) > (16u << 20) || ec) return std::nullopt;
  std::ifstream in(p);
  json j = json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || j.value("format", "") != "hdrd-sequence") return std::nullopt;
  return j;
}

std::optional<double> number(const json& j, const char* key) {
  if (auto it = j.find(key); it != j.end() && it->is_number()) return it->get<double>();
  return std::nullopt;
}

Result<DumpSequence> from_sequence_sidecar(const fs::path& p, const json& j) {
  DumpSequence seq;
  const json& files = j.value("files", json::object());
  const json& frames = files.is_object() ? files.value("frames", json::object()) : json();
  if (!frames.is_object() || !frames.contains("sidecar") || !frames["sidecar"].is_string())
    return sequence_error(fmt::format("{}: the sequence wrote no per-frame dumps (files.frames.sidecar); render it "
                                      "with --format raw", p.string()));
  const fs::path spec = p.parent_path() / frames["sidecar"].get<std::string>();
  if (!io::is_frame_pattern(spec))
    return sequence_error(fmt::format("{}: files.frames.sidecar is not a frame pattern", p.string()));
  auto found = io::file_sequence(spec, dump_rules());
  if (!found) return found.error();
  seq.sidecars = std::move(*found);
  if (auto fps = number(j, "fps"); fps && *fps > 0 && *fps <= 1000) seq.fps = *fps;
  if (const json& cl = j.value("content_light_level", json()); cl.is_object()) {
    seq.content_light.max_cll_nits = number(cl, "max_cll_nits_measured").value_or(number(cl, "max_cll_nits").value_or(0));
    seq.content_light.max_fall_nits = number(cl, "max_fall_nits_measured").value_or(number(cl, "max_fall_nits").value_or(0));
  }
  return seq;
}

Result<DumpSequence> expand(const std::vector<std::string>& inputs) {
  if (inputs.empty()) return sequence_error("no dumps given");
  DumpSequence seq;
  if (inputs.size() > 1) {
    for (const auto& i : inputs) seq.sidecars.emplace_back(i);
    return seq;
  }
  const fs::path spec = inputs.front();
  Result<std::vector<fs::path>> files = std::vector<fs::path>{};
  if (io::names_a_file_sequence(spec)) files = io::file_sequence(spec, dump_rules());
  else if (const auto j = sequence_sidecar(spec)) return from_sequence_sidecar(spec, *j);
  else files = std::vector<fs::path>{spec};
  if (!files) return files.error();
  seq.sidecars = std::move(*files);
  return seq;
}

}  // namespace

bool names_a_dump_sequence(const std::vector<std::string>& inputs) {
  if (inputs.size() != 1) return inputs.size() > 1;
  const fs::path spec = inputs.front();
  return io::names_a_file_sequence(spec) || sequence_sidecar(spec);
}

Result<DumpSequence> open_dump_sequence(const std::vector<std::string>& inputs) {
  auto seq = expand(inputs);
  if (!seq) return seq;
  const bool known_light = seq->content_light.max_cll_nits > 0;
  for (std::size_t i = 0; i < seq->sidecars.size(); ++i) {
    auto h = read_dump_header(seq->sidecars[i]);
    if (!h) return h.error();
    const EncodedFrame& f = h->frame;
    if (i == 0) {
      seq->width = f.width;
      seq->height = f.height;
      seq->mode = f.target.mode;
    } else if (f.width != seq->width || f.height != seq->height || f.target.mode != seq->mode) {
      return sequence_error(fmt::format("{} is {}x{} {}; the sequence's first frame ({}) is {}x{} {}",
                                        seq->sidecars[i].string(), f.width, f.height, to_string(f.target.mode),
                                        seq->sidecars[0].string(), seq->width, seq->height, to_string(seq->mode)));
    }
    if (!known_light) {  // CTA-861.3: the brightest pixel and the brightest frame average of any frame
      seq->content_light.max_cll_nits = std::max(seq->content_light.max_cll_nits, f.content_light.max_cll_nits);
      seq->content_light.max_fall_nits = std::max(seq->content_light.max_fall_nits, f.content_light.max_fall_nits);
    }
  }
  return seq;
}

}  // namespace hdrd::display

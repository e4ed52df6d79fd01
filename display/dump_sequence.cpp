#include "display/dump_sequence.hpp"

#include <algorithm>
#include <fstream>
#include <regex>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/dump_reader.hpp"

namespace hdrd::display {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxFrames = 1'000'000;

Error sequence_error(std::string message) { return make_error("dump.sequence", std::move(message), "input"); }

struct FramePattern {
  std::string prefix, suffix;
  int width = 0;  // %05d: 5; %d: 0
};

// "shot.%05d.json" -> {"shot.", ".json", 5}. Exactly one %d / %0Nd; "%%" is a literal '%'.
std::optional<FramePattern> parse_pattern(const std::string& name) {
  static const std::regex re(R"(^(.*?)%(0([1-9]))?d(.*)$)");
  std::smatch m;
  if (!std::regex_match(name, m, re) || m[4].str().find('%') != std::string::npos) return std::nullopt;
  return FramePattern{m[1], m[4], m[3].matched ? std::stoi(m[3]) : 0};
}

Result<std::vector<fs::path>> pattern_files(const fs::path& spec, const FramePattern& p) {
  const fs::path dir = spec.has_parent_path() ? spec.parent_path() : fs::path(".");
  std::vector<std::pair<long long, fs::path>> found;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= p.prefix.size() + p.suffix.size() || name.rfind(p.prefix, 0) != 0 ||
        name.compare(name.size() - p.suffix.size(), p.suffix.size(), p.suffix) != 0)
      continue;
    const std::string digits = name.substr(p.prefix.size(), name.size() - p.prefix.size() - p.suffix.size());
    if (digits.size() > 12 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    if (p.width ? digits.size() < static_cast<std::size_t>(p.width) : digits.size() > 1 && digits[0] == '0') continue;
    found.emplace_back(std::stoll(digits), it->path());
    if (found.size() > kMaxFrames) return sequence_error(fmt::format("{}: more than {} frames", spec.string(), kMaxFrames));
  }
  if (ec) return sequence_error(fmt::format("{}: cannot read the directory {}: {}", spec.string(), dir.string(), ec.message()));
  if (found.empty()) return sequence_error(fmt::format("{}: no file matches the pattern", spec.string()));
  std::sort(found.begin(), found.end());
  std::vector<fs::path> files;
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (i > 0 && found[i].first != found[i - 1].first + 1)
      return sequence_error(fmt::format("{}: frame {} is missing (frames {}..{} exist, then {})", spec.string(),
                                        found[i - 1].first + 1, found.front().first, found[i - 1].first,
                                        found[i].first));
    files.push_back(found[i].second);
  }
  return files;
}

Result<std::vector<fs::path>> directory_files(const fs::path& dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() != ".json") continue;
    fs::path raw = it->path();
    raw.replace_extension(".raw");
    if (fs::is_regular_file(raw, ec)) files.push_back(it->path());
  }
  if (ec) return sequence_error(fmt::format("{}: cannot read the directory: {}", dir.string(), ec.message()));
  if (files.empty()) return sequence_error(fmt::format("{}: the directory holds no raw dump (NAME.json + NAME.raw)", dir.string()));
  std::sort(files.begin(), files.end());
  return files;
}

Result<std::vector<fs::path>> list_files(const fs::path& list) {
  std::ifstream in(list);
  if (!in) return sequence_error(fmt::format("{}: cannot open the list file", list.string()));
  std::vector<fs::path> files;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.size() > 4096) return sequence_error(fmt::format("{}:{}: a line longer than 4096 bytes", list.string(), number));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    fs::path p = line.substr(first, line.find_last_not_of(" \t") - first + 1);
    files.push_back(p.is_relative() ? list.parent_path() / p : p);
    if (files.size() > kMaxFrames) return sequence_error(fmt::format("{}: more than {} frames", list.string(), kMaxFrames));
  }
  if (files.empty()) return sequence_error(fmt::format("{}: the list names no file", list.string()));
  return files;
}

bool is_list_file(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".txt" || ext == ".lst" || ext == ".list";
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
  const auto pattern = parse_pattern(spec.filename().string());
  if (!pattern) return sequence_error(fmt::format("{}: files.frames.sidecar is not a frame pattern", p.string()));
  auto found = pattern_files(spec, *pattern);
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
  std::error_code ec;
  Result<std::vector<fs::path>> files = std::vector<fs::path>{};
  if (const auto p = parse_pattern(spec.filename().string())) files = pattern_files(spec, *p);
  else if (fs::is_directory(spec, ec)) files = directory_files(spec);
  else if (is_list_file(spec)) files = list_files(spec);
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
  std::error_code ec;
  return parse_pattern(spec.filename().string()) || fs::is_directory(spec, ec) || is_list_file(spec) ||
         sequence_sidecar(spec);
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

#include "encode/io/file_sequence.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>
#include <optional>
#include <regex>
#include <string>

#include <fmt/format.h>

namespace hdrd::io {
namespace fs = std::filesystem;

namespace {

// "shot.%04d.exr" -> prefix "shot.", width 4, suffix ".exr"; nullopt when the name holds
// no single %d / %0Nd conversion.
struct FramePattern {
  std::string prefix, suffix;
  int width = 0;
};
std::optional<FramePattern> parse_frame_pattern(const std::string& name) {
  static const std::regex conversion(R"(^(.*?)%(0?([1-9]))?d(.*)$)");
  std::smatch m;
  if (!std::regex_match(name, m, conversion)) return std::nullopt;
  FramePattern p{m[1].str(), m[4].str(), m[3].matched ? std::stoi(m[3].str()) : 0};
  if (p.prefix.find('%') != std::string::npos || p.suffix.find('%') != std::string::npos) return std::nullopt;
  return p;
}

struct Failer {
  const FileSequenceRules& rules;
  Error operator()(std::string message) const {
    return make_error(std::string(rules.code), std::move(message), std::string(rules.field));
  }
};

Result<std::vector<fs::path>> pattern_files(const fs::path& spec, const FramePattern& p, const FileSequenceRules& rules) {
  const Failer fail{rules};
  const fs::path dir = spec.has_parent_path() ? spec.parent_path() : fs::path(".");
  std::error_code ec;
  std::vector<std::pair<long long, fs::path>> found;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= p.prefix.size() + p.suffix.size() || n.compare(0, p.prefix.size(), p.prefix) != 0 ||
        n.compare(n.size() - p.suffix.size(), p.suffix.size(), p.suffix) != 0)
      continue;
    const std::string digits = n.substr(p.prefix.size(), n.size() - p.prefix.size() - p.suffix.size());
    if (digits.size() > 12 || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
      continue;
    if (p.width > 0 && digits.size() < static_cast<std::size_t>(p.width)) continue;  // %04d writes at least 4
    if (p.width > 0 && digits.size() > static_cast<std::size_t>(p.width) && digits[0] == '0') continue;
    if (p.width == 0 && digits.size() > 1 && digits[0] == '0') continue;  // %d writes no leading zeros
    found.emplace_back(std::stoll(digits), it->path());
    if (found.size() > rules.max_files) return fail(fmt::format("{}: more than {} frames", spec.string(), rules.max_files));
  }
  if (ec) return fail(fmt::format("{}: cannot read the directory {}: {}", spec.string(), dir.string(), ec.message()));
  if (found.empty()) return fail(fmt::format("{}: no file matches the pattern", spec.string()));
  std::sort(found.begin(), found.end());
  std::vector<fs::path> files;
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (i > 0 && found[i].first == found[i - 1].first)
      return fail(fmt::format("{}: frame {} exists twice", spec.string(), found[i].first));
    if (i > 0 && found[i].first != found[i - 1].first + 1)
      return fail(fmt::format("{}: frame {} is missing (frames {}..{} exist, then {})", spec.string(),
                              found[i - 1].first + 1, found.front().first, found[i - 1].first, found[i].first));
    files.push_back(found[i].second);
  }
  return files;
}

Result<std::vector<fs::path>> directory_files(const fs::path& dir, const FileSequenceRules& rules) {
  const Failer fail{rules};
  std::error_code ec;
  std::vector<fs::path> files;
  std::string want(rules.extension);
  std::transform(want.begin(), want.end(), want.begin(), [](unsigned char c) { return std::tolower(c); });
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::string ext = it->path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    std::error_code file_ec;
    if (ext != want || !it->is_regular_file(file_ec) || (rules.accept && !rules.accept(it->path()))) continue;
    files.push_back(it->path());
    if (files.size() > rules.max_files) return fail(fmt::format("{}: more than {} frames", dir.string(), rules.max_files));
  }
  if (ec) return fail(fmt::format("{}: cannot read the directory: {}", dir.string(), ec.message()));
  if (files.empty()) return fail(fmt::format("{}: the directory holds no {}", dir.string(), rules.what));
  std::sort(files.begin(), files.end());
  return files;
}

Result<std::vector<fs::path>> list_files(const fs::path& list, const FileSequenceRules& rules) {
  const Failer fail{rules};
  auto text = rules.files.read(list, std::size_t{64} << 20);
  if (!text && text.error().code.rfind("path.", 0) == 0 && text.error().code != "path.not_found") return text.error();
  if (!text) return fail(fmt::format("{}: cannot open the list file ({})", list.string(), text.error().message));
  std::istringstream in(*text);
  std::vector<fs::path> files;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.size() > 4096) return fail(fmt::format("{}:{}: a line longer than 4096 bytes", list.string(), number));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t");
    fs::path p = line.substr(first, last - first + 1);
    if (p.is_relative()) p = list.parent_path() / p;
    files.push_back(std::move(p));
    if (files.size() > rules.max_files) return fail(fmt::format("{}: more than {} frames", list.string(), rules.max_files));
  }
  if (files.empty()) return fail(fmt::format("{}: the list names no file", list.string()));
  return files;
}

}  // namespace

bool is_frame_pattern(const fs::path& spec) { return parse_frame_pattern(spec.filename().string()).has_value(); }

bool is_list_file(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".txt" || ext == ".lst" || ext == ".list";
}

bool names_a_file_sequence(const fs::path& spec) {
  std::error_code ec;
  return is_frame_pattern(spec) || fs::is_directory(spec, ec) || is_list_file(spec);
}

Result<std::vector<fs::path>> file_sequence(const fs::path& spec, const FileSequenceRules& rules) {
  const Failer fail{rules};
  if (const auto p = parse_frame_pattern(spec.filename().string())) return pattern_files(spec, *p, rules);
  std::error_code ec;
  if (fs::is_directory(spec, ec)) return directory_files(spec, rules);
  if (is_list_file(spec)) return list_files(spec, rules);
  return fail(fmt::format("{}: not a frame pattern (%04d), a directory or a list file (.txt)", spec.string()));
}

}  // namespace hdrd::io

#include "daemon/http/accept.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <optional>
#include <vector>

#include <fmt/format.h>

namespace hdrd::daemon {
namespace {

std::string trim_lower(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

struct MediaRange {
  std::string type, subtype;
  double q = 1.0;
};

std::vector<MediaRange> parse_accept(std::string_view accept) {
  std::vector<MediaRange> out;
  while (!accept.empty() && out.size() < 64) {
    const auto comma = accept.find(',');
    std::string_view item = accept.substr(0, comma);
    accept = comma == std::string_view::npos ? std::string_view{} : accept.substr(comma + 1);
    const auto semi = item.find(';');
    const std::string range = trim_lower(item.substr(0, semi));
    const auto slash = range.find('/');
    if (slash == std::string::npos) continue;
    MediaRange m{range.substr(0, slash), range.substr(slash + 1), 1.0};
    for (std::string_view params = semi == std::string_view::npos ? std::string_view{} : item.substr(semi + 1);
         !params.empty();) {
      const auto next = params.find(';');
      const std::string p = trim_lower(params.substr(0, next));
      params = next == std::string_view::npos ? std::string_view{} : params.substr(next + 1);
      if (p.rfind("q=", 0) == 0) {
        char* end = nullptr;
        const double q = std::strtod(p.c_str() + 2, &end);
        m.q = (end && *end == '\0' && q >= 0 && q <= 1) ? q : 0.0;
      }
    }
    out.push_back(m);
  }
  return out;
}

// The q-value the Accept header gives a concrete media type: the most specific range wins.
double quality(const std::vector<MediaRange>& ranges, std::string_view type) {
  const auto slash = type.find('/');
  const std::string_view t = type.substr(0, slash), st = type.substr(slash + 1);
  int best_specificity = -1;
  double q = 0;
  for (const auto& r : ranges) {
    int spec = -1;
    if (r.type == t && r.subtype == st) spec = 2;
    else if (r.type == t && r.subtype == "*") spec = 1;
    else if (r.type == "*" && r.subtype == "*") spec = 0;
    if (spec > best_specificity) {
      best_specificity = spec;
      q = r.q;
    }
  }
  return q;
}

std::vector<MediaRange> ranges_of(const std::string* accept) {
  const bool has_accept = accept && !trim_lower(*accept).empty();
  return has_accept ? parse_accept(*accept) : std::vector<MediaRange>{{"*", "*", 1.0}};
}

}  // namespace

Result<void> accepts_json(const std::string* accept) {
  if (quality(ranges_of(accept), "application/json") > 0) return {};
  return make_error("request.not_acceptable", "with \"dump\": true the answer is JSON; Accept does not allow application/json",
                    "dump");
}

Result<job::Output> negotiate_output(const std::string* accept, Mode mode, job::Source source) {
  const auto ranges = ranges_of(accept);
  std::optional<job::Output> best;
  double best_q = 0;
  std::string offered;
  for (const auto& o : job::outputs()) {
    if (!o.reply || !job::applies(o, source, mode)) continue;
    offered += (offered.empty() ? "" : ", ") + std::string(o.content_type);
    const double q = quality(ranges, o.content_type);
    if (q > best_q) best_q = q, best = o.id;
  }
  if (best) return *best;
  if (!mode_info(mode).png && quality(ranges, "image/png") > 0)
    return make_error("request.not_acceptable",
                      fmt::format("{} has no PNG form: ask for {}", to_string(mode), offered), "display.mode");
  return make_error("request.not_acceptable", fmt::format("Accept allows none of {}", offered), "");
}

}  // namespace hdrd::daemon

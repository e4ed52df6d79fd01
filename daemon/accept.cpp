#include "daemon/accept.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <vector>

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

}  // namespace

std::string_view content_type(OutputKind k) {
  switch (k) {
    case OutputKind::png: return "image/png";
    case OutputKind::exr: return "image/x-exr";
    case OutputKind::raw: return "application/octet-stream";
    case OutputKind::json_dump: return "application/json";
  }
  return "application/octet-stream";
}

Result<OutputKind> negotiate_output(const std::string* accept, Mode mode, bool dump) {
  const bool has_accept = accept && !trim_lower(*accept).empty();
  const auto ranges = has_accept ? parse_accept(*accept) : std::vector<MediaRange>{{"*", "*", 1.0}};
  if (dump) {
    if (quality(ranges, "application/json") > 0) return OutputKind::json_dump;
    return make_error("request.not_acceptable",
                      "with \"dump\": true the answer is JSON; Accept does not allow application/json", "dump");
  }
  // Our preference order breaks ties: the mode's natural image format first.
  std::vector<OutputKind> order = {OutputKind::png, OutputKind::exr, OutputKind::raw};
  if (mode == Mode::scrgb) order = {OutputKind::exr, OutputKind::raw};
  OutputKind best = order.front();
  double best_q = 0;
  for (OutputKind k : order) {
    const double q = quality(ranges, content_type(k));
    if (q > best_q) {
      best_q = q;
      best = k;
    }
  }
  if (best_q > 0) return best;
  if (mode == Mode::scrgb && quality(ranges, "image/png") > 0)
    return make_error("request.not_acceptable", "scrgb has no PNG form: ask for image/x-exr or application/octet-stream",
                      "display.mode");
  return make_error("request.not_acceptable",
                    "Accept allows none of image/png, image/x-exr, application/octet-stream (raw DRM buffer)", "");
}

}  // namespace hdrd::daemon

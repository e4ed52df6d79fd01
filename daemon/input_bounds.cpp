#include "daemon/input_bounds.hpp"

#include <fmt/format.h>


namespace hdrd::daemon {
namespace {

// A name as it may appear in a message or a field: one line, valid UTF-8, short.
std::string shown(std::string_view s) {
  std::string out = one_line(s.substr(0, 64));
  if (!io::is_valid_utf8(out)) {
    for (char& c : out)
      if (static_cast<unsigned char>(c) >= 0x80) c = '?';
  }
  return out;
}

}  // namespace

Result<void> check_query(const std::vector<std::pair<std::string, std::string>>& query) {
  if (query.size() > kMaxQueryParams)
    return make_error("request.query", fmt::format("{} query parameters, at most {}", query.size(), kMaxQueryParams));
  for (const auto& [key, value] : query) {
    const std::string name = shown(key);
    for (const std::string* s : {&key, &value}) {
      const char* part = s == &key ? "name" : "value";
      if (s->size() > kMaxQueryBytes)
        return make_error("request.query", fmt::format("query parameter '{}': {} longer than {} bytes", name, part,
                                                       kMaxQueryBytes), name);
      if (s->find('\0') != std::string::npos)
        return make_error("request.query", fmt::format("query parameter '{}': {} holds a NUL byte (%00)", name, part),
                          name);
      if (!io::is_valid_utf8(*s))
        return make_error("request.query", fmt::format("query parameter '{}': {} is not valid UTF-8 once "
                                                       "percent-decoded", name, part), name);
    }
  }
  return {};
}

Result<EncodeUpload> split_encode_upload(std::vector<Part>& parts, const Limits& limits) {
  EncodeUpload up;
  bool have_image = false, have_request = false;
  for (auto& p : parts) {
    if (p.name == "image" && !have_image) {
      up.exr = std::move(p.data);
      have_image = true;
    } else if (p.name == "request" && !have_request) {
      auto options = parse_json_object_bounded(p.data, limits, "the 'request' part");
      if (!options) {
        Error e = options.error();
        if (e.field.empty()) e.field = "request";  // the part itself; else the request field
        return e;
      }
      up.options = std::move(*options);
      have_request = true;
    } else {
      const std::string name = shown(p.name);
      return make_error("request.unknown_field",
                        fmt::format("multipart part '{}': expected one 'image' and at most one 'request'", name), name);
    }
  }
  if (!have_image) return make_error("request.value", "multipart body has no 'image' part (the EXR)", "image");
  return up;
}

}  // namespace hdrd::daemon

#include "daemon/http/input_bounds.hpp"

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
      for (unsigned char b : *s)
        if (b < 0x20 || b == 0x7f)
          return make_error("request.query", fmt::format("query parameter '{}': {} holds control byte 0x{:02x}", name,
                                                         part, b), name);
      if (!io::is_valid_utf8(*s))
        return make_error("request.query", fmt::format("query parameter '{}': {} is not valid UTF-8 once "
                                                       "percent-decoded", name, part), name);
    }
  }
  return {};
}

Result<void> check_request_target(std::string_view raw) {
  const auto hex = [](char c) {
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
  };
  const auto control = [](unsigned b) { return b < 0x20 || b == 0x7f; };
  bool in_query = false;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const unsigned b = static_cast<unsigned char>(raw[i]);
    in_query = in_query || b == '?';
    if (control(b))
      return make_error("request.target", fmt::format("the request target holds control byte 0x{:02x} at offset {}", b, i));
    // Percent-encoded ones in the path; the query's are check_query's, which names the parameter.
    if (b == '%' && i + 2 < raw.size() && !in_query) {
      const int hi = hex(raw[i + 1]), lo = hex(raw[i + 2]);
      if (hi >= 0 && lo >= 0 && control(unsigned(hi * 16 + lo)))
        return make_error("request.target", fmt::format("the request target holds control byte 0x{:02x} "
                                                        "(percent-encoded) at offset {}", hi * 16 + lo, i));
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

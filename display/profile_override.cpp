// Profile overrides: a user's measured or preferred values for one display (matched by
// its EDID identity) from config files, or for one request. TOML files are converted to
// JSON first so both go through one validating parser.
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "display/profile.hpp"
#include "encode/io/json_text.hpp"

namespace hdrd::display {
namespace {

using nlohmann::json;

Error bad(const std::string& source, const std::string& field, std::string message) {
  return make_error("profile.override", fmt::format("{}: {}", source, message), field);
}

json toml_to_json(const toml::node& n) {
  if (const auto* t = n.as_table()) {
    json o = json::object();
    for (const auto& [k, v] : *t) o[std::string(k.str())] = toml_to_json(v);
    return o;
  }
  if (const auto* a = n.as_array()) {
    json arr = json::array();
    for (const auto& v : *a) arr.push_back(toml_to_json(v));
    return arr;
  }
  if (auto v = n.value<bool>(); v && n.is_boolean()) return *v;
  if (n.is_integer()) return *n.value<std::int64_t>();
  if (n.is_floating_point()) return *n.value<double>();
  if (n.is_string()) return *n.value<std::string>();
  return nullptr;  // dates and times: no profile key takes them, so they fail as mistyped
}

Result<double> number(const json& j, const char* key, const std::string& source) {
  if (!j.is_number()) return bad(source, key, fmt::format("'{}' must be a number", key));
  const double v = j.get<double>();
  if (!std::isfinite(v)) return bad(source, key, fmt::format("'{}' must be finite", key));
  return v;
}

Result<color::Chromaticity> xy(const json& j, const char* key, const std::string& source) {
  if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number())
    return bad(source, "primaries", fmt::format("primaries.{} must be [x, y]", key));
  return color::Chromaticity{j[0].get<double>(), j[1].get<double>()};
}

Result<color::Primaries> primaries(const json& j, const std::string& source) {
  if (j.is_string()) {
    const auto space = color::find_space(j.get<std::string>());
    if (!space || *space == color::Space::xyz)
      return bad(source, "primaries", fmt::format("unknown colour space '{}'", j.get<std::string>()));
    return color::info(*space).primaries;
  }
  if (!j.is_object()) return bad(source, "primaries", "primaries must be a colour space name or {red, green, blue, white}");
  color::Primaries p;
  const std::pair<const char*, color::Chromaticity*> parts[] = {
      {"red", &p.red}, {"green", &p.green}, {"blue", &p.blue}, {"white", &p.white}};
  for (const auto& [key, dst] : parts) {
    if (!j.contains(key)) return bad(source, "primaries", fmt::format("primaries.{} is missing", key));
    auto c = xy(j[key], key, source);
    if (!c) return c.error();
    *dst = *c;
  }
  return p;
}

Result<void> parse_match(const json& m, ProfileOverride& o) {
  if (!m.is_object()) return bad(o.source, "match", "[match] must be a table");
  for (const auto& [k, v] : m.items()) {
    if (k == "manufacturer" && v.is_string()) o.match_manufacturer = v.get<std::string>();
    else if (k == "name" && v.is_string()) o.match_name = v.get<std::string>();
    else if (k == "product_code" && v.is_number_integer() && v.get<std::int64_t>() >= 0 && v.get<std::int64_t>() <= 0xffff)
      o.match_product_code = static_cast<std::uint16_t>(v.get<std::int64_t>());
    else if (k == "product_code" && v.is_string()) {
      const std::string text = v.get<std::string>();  // strtol's end pointer points into it
      char* end = nullptr;
      const long code = std::strtol(text.c_str(), &end, 0);
      if (!end || *end || code < 0 || code > 0xffff) return bad(o.source, "match.product_code", "product_code must be 0..65535");
      o.match_product_code = static_cast<std::uint16_t>(code);
    } else {
      return bad(o.source, "match." + k, fmt::format("unknown or mistyped match key '{}'", k));
    }
  }
  return {};
}

Result<void> parse_values(const json& p, ProfileOverride& o) {
  if (!p.is_object()) return bad(o.source, "profile", "[profile] must be a table");
  for (const auto& [k, v] : p.items()) {
    if (k == "mode") {
      if (!v.is_string() || !parse_mode(v.get<std::string>()))
        return bad(o.source, "mode", "mode must be one of hdr10, hlg, scrgb, sdr, sdr-bt1886");
      o.mode = parse_mode(v.get<std::string>());
    } else if (k == "peak_nits" || k == "frame_average_nits" || k == "black_nits") {
      auto n = number(v, k.c_str(), o.source);
      if (!n) return n.error();
      (k == "peak_nits" ? o.peak_nits : k == "black_nits" ? o.black_nits : o.frame_average_nits) = *n;
    } else if (k == "primaries") {
      auto pr = primaries(v, o.source);
      if (!pr) return pr.error();
      o.primaries = *pr;
    } else if (k == "name" && v.is_string()) {
      o.name = v.get<std::string>();
    } else {
      return bad(o.source, k, fmt::format("unknown or mistyped profile key '{}'", k));
    }
  }
  return {};
}

}  // namespace

bool ProfileOverride::matches(const Profile& p) const {
  if (match_manufacturer && *match_manufacturer != p.manufacturer) return false;
  if (match_product_code && *match_product_code != p.product_code) return false;
  if (match_name && *match_name != p.name) return false;
  return true;
}

Result<ProfileOverride> parse_profile_override(const json& j, const std::string& source) {
  ProfileOverride o;
  o.source = source;
  if (!j.is_object()) return bad(source, "", "a profile override must be an object");
  if (j.contains("match") || j.contains("profile")) {
    for (const auto& [k, v] : j.items())
      if (k != "match" && k != "profile") return bad(source, k, fmt::format("unknown top-level key '{}'", k));
    if (j.contains("match"))
      if (auto r = parse_match(j["match"], o); !r) return r.error();
    if (j.contains("profile"))
      if (auto r = parse_values(j["profile"], o); !r) return r.error();
  } else if (auto r = parse_values(j, o); !r) {
    return r.error();
  }
  return o;
}

Result<ProfileOverride> parse_profile_override_toml(std::string_view text, const std::string& source) {
  try {
    const toml::table t = toml::parse(text, source);
    return parse_profile_override(toml_to_json(t), source);
  } catch (const toml::parse_error& e) {
    return bad(source, "", fmt::format("TOML syntax error at line {}: {}", e.source().begin.line, e.description()));
  }
}

Result<ProfileOverride> load_profile_override(const std::filesystem::path& path, const io::InputFiles& files) {
  auto bytes = read_binary_file(path, 1 << 20, files);
  if (!bytes) return bytes.error();
  const std::string text(bytes->begin(), bytes->end());
  const std::string ext = path.extension().string();
  if (ext == ".toml") return parse_profile_override_toml(text, path.string());
  if (ext == ".json") {
    auto j = io::parse_json_bounded(text, io::JsonBounds{1u << 20, 64, "profile override", "profile.json_"});
    if (!j) return bad(path.string(), "", j.error().message);
    return parse_profile_override(*j, path.string());
  }
  return bad(path.string(), "", "profile overrides are .toml or .json files");
}

Result<std::vector<ProfileOverride>> load_profile_overrides(const std::filesystem::path& dir) {
  std::vector<ProfileOverride> out;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return out;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.is_regular_file() && (e.path().extension() == ".toml" || e.path().extension() == ".json"))
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    auto o = load_profile_override(f);
    if (!o) return o.error();
    out.push_back(std::move(*o));
  }
  return out;
}

Result<Profile> apply_override(Profile p, const ProfileOverride& o) {
  std::vector<std::string> changed;
  if (o.mode) { p.mode = *o.mode; changed.push_back(fmt::format("mode {}", to_string(*o.mode))); }
  if (o.peak_nits) { p.peak_nits = *o.peak_nits; changed.push_back(fmt::format("peak {} cd/m2", *o.peak_nits)); }
  if (o.frame_average_nits) {
    p.frame_average_nits = *o.frame_average_nits;
    changed.push_back(fmt::format("frame-average {} cd/m2", *o.frame_average_nits));
  } else if (o.peak_nits && p.frame_average_nits > p.peak_nits) {
    p.frame_average_nits = p.peak_nits;  // keep the pair consistent when only the peak moved
  }
  if (o.black_nits) { p.black_nits = *o.black_nits; changed.push_back(fmt::format("black {} cd/m2", *o.black_nits)); }
  if (o.primaries) { p.primaries = *o.primaries; changed.push_back("primaries"); }
  if (o.name) { p.name = *o.name; changed.push_back(fmt::format("name '{}'", *o.name)); }
  if (o.mode) p.mode_reason = "set by override " + o.source;
  p.notes.push_back(fmt::format("override {}: {}", o.source, changed.empty() ? "no values" : fmt::format("{}", fmt::join(changed, ", "))));
  p.source += "+override:" + o.source;
  if (auto v = validate_profile(p); !v) {
    Error e = v.error();
    e.message = fmt::format("{} (after override {})", e.message, o.source);
    return e;
  }
  return p;
}

Result<Profile> apply_matching_overrides(Profile p, const std::vector<ProfileOverride>& overrides) {
  for (const auto& o : overrides) {
    if (!o.has_match() || !o.matches(p)) continue;
    auto r = apply_override(std::move(p), o);
    if (!r) return r.error();
    p = std::move(*r);
  }
  return p;
}

std::vector<std::filesystem::path> default_profile_dirs() {
  std::vector<std::filesystem::path> dirs;
  if (const char* d = std::getenv("HDRD_PROFILE_DIR"); d && *d) dirs.emplace_back(d);
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x && *x) dirs.push_back(std::filesystem::path(x) / "hdrd/profiles");
  else if (const char* h = std::getenv("HOME"); h && *h) dirs.push_back(std::filesystem::path(h) / ".config/hdrd/profiles");
  dirs.emplace_back("/etc/hdrd/profiles");
  return dirs;
}

}  // namespace hdrd::display

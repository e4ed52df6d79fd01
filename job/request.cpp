// The one request parser: JSON bodies, CLI flags and query parameters all become a JSON
// object first, then every leaf is checked against its entry in the settings table, and
// the rules that tie settings together are checked once (check_rules).
#include "job/request.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "encode/display_target.hpp"
#include "encode/grade/lut.hpp"
#include "encode/io/digest.hpp"
#include "encode/tone/tonemap.hpp"
#include "job/outputs.hpp"
#include "job/pattern_params.hpp"

namespace hdrd::job {
namespace {

using nlohmann::json;

// Inside the parser a failure unwinds to parse_request_json(), the one place that turns
// it back into a Result (exceptions inside, one boundary).
struct Fail {
  Error error;
};
[[noreturn]] void fail(std::string code, const std::string& message, std::string field) {
  throw Fail{make_error(std::move(code), one_line(message), std::move(field))};
}

std::string join(std::string_view prefix, std::string_view key) {
  return prefix.empty() ? std::string(key) : std::string(prefix) + "." + std::string(key);
}

std::string_view type_name(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return "null";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::string: return "a string";
    case json::value_t::array: return "an array";
    case json::value_t::object: return "an object";
    case json::value_t::binary: return "binary";
    case json::value_t::discarded: return "discarded";
    default: return "a number";
  }
}

std::string choices_text(std::span<const std::string_view> choices) {
  std::string s;
  for (auto c : choices) s += (s.empty() ? "" : ", ") + std::string(c);
  return s;
}

class Parser {
 public:
  Parser(const ParseContext& ctx, FrameRequest& r) : ctx_(ctx), r_(r) {}

  void walk(const json& obj, const std::string& prefix) {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      if (it.key().size() > 128) fail("request.limit", "a field name longer than 128 bytes", prefix);
      const std::string path = join(prefix, it.key());
      if (const Setting* s = find_setting(path)) {
        leaf(*s, path, *it);
      } else if (is_group(path) && it->is_object()) {
        walk(*it, path);
      } else if (is_group(path)) {
        fail("request.type", fmt::format("{}: expected an object, got {}", shown(path), type_name(*it)), path);
      } else {
        fail("request.unknown_field", fmt::format("{}: unknown field", shown(path)), path);
      }
    }
  }

 private:
  std::string shown(std::string_view path) const { return label(path, ctx_.spelling); }

  void leaf(const Setting& s, const std::string& spelled, const json& v) {
    const std::string path(s.path);
    if (!s.takes(ctx_.source))
      fail("request.unknown_field",
           fmt::format("{}: does not apply to {} requests{}", shown(path), to_string(ctx_.source),
                       ctx_.source == Source::pattern ? " (patterns are display light, encoded with the clip curve)"
                                                      : ""),
           path);
    if (s.reach == Reach::cli && ctx_.reach == Reach::daemon)
      fail("request.unknown_field", fmt::format("{}: set by the daemon's configuration, not per request", shown(path)),
           path);
    if (s.sequence && !ctx_.sequence)
      fail("request.unknown_field",
           fmt::format("{}: a sequence setting (hdrd render/encode --frames, POST /v1/sequences)", shown(path)), path);
    if (s.reach == Reach::daemon && ctx_.reach == Reach::cli)
      fail("request.unknown_field", fmt::format("{}: only the daemon takes it", shown(path)), path);
    json value = check(s, path, v);
    if (auto prev = r_.values.find(path); prev != r_.values.end() && r_.given.count(path)) {
      if (prev->second != value)
        fail("request.conflict", fmt::format("{} and {} are the same setting and disagree: give one", s.path, s.alias),
             path);
      return;
    }
    r_.values[path] = std::move(value);
    r_.given.insert(path);
  }

  double number(const std::string& path, const json& v, double min, double max) {
    if (!v.is_number()) fail("request.type", fmt::format("{}: expected a number, got {}", shown(path), type_name(v)), path);
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail("request.value", shown(path) + ": must be a finite number", path);
    if (d < min || d > max)
      fail("request.value", fmt::format("{}: {:g} is outside [{:g}, {:g}]", shown(path), d, min, max), path);
    return d;
  }

  json check(const Setting& s, const std::string& path, const json& v) {
    switch (s.type) {
      case Type::number: return json(number(path, v, s.min, s.max));
      case Type::integer: {
        if (!v.is_number())
          fail("request.type", fmt::format("{}: expected an integer, got {}", shown(path), type_name(v)), path);
        const double d = v.get<double>();
        if (!std::isfinite(d) || d != std::floor(d))
          fail("request.type", fmt::format("{}: expected an integer, got {}", shown(path), v.dump()), path);
        if (d < s.min || d > s.max)
          fail(d > s.max && s.size_limit ? "request.limit" : "request.value",
               fmt::format("{}: {:.0f} is outside [{:g}, {:g}]", shown(path), d, s.min, s.max), path);
        return static_cast<std::int64_t>(d);
      }
      case Type::boolean:
        if (!v.is_boolean())
          fail("request.type", fmt::format("{}: expected true or false, got {}", shown(path), type_name(v)), path);
        return v;
      case Type::choice: {
        const std::string& c = text(s, path, v);
        if (std::find(s.choices.begin(), s.choices.end(), c) == s.choices.end() && !accepted_alias(s, c))
          fail("request.value",
               fmt::format("{}: unknown value '{}' (one of: {})", shown(path), c.substr(0, 64), choices_text(s.choices)),
               path);
        return canonical_choice(s, c);
      }
      case Type::text: return text(s, path, v);
      case Type::path: {
        const std::string& p = text(s, path, v);
        if (p.empty()) fail("request.value", shown(path) + ": empty path", path);
        return resolve(p, path).string();
      }
      case Type::vec3: {
        if (!v.is_array() || v.size() != 3)
          fail("request.type", fmt::format("{}: expected an array of 3 numbers, got {}", shown(path), type_name(v)), path);
        json out = json::array();
        for (std::size_t i = 0; i < 3; ++i) out.push_back(number(path, v[i], -s.max, s.max));
        return out;
      }
      case Type::number_map: {
        if (!v.is_object())
          fail("request.type", fmt::format("{}: expected an object of numbers, got {}", shown(path), type_name(v)), path);
        if (v.size() > 32) fail("request.limit", shown(path) + ": at most 32 entries", path);
        json out = json::object();
        for (auto it = v.begin(); it != v.end(); ++it) {
          if (it.key().empty() || it.key().size() > 64)
            fail("request.value", shown(path) + ": names are 1 to 64 bytes", path);
          out[it.key()] = number(join(path, it.key()), *it, s.min, s.max);
        }
        return out;
      }
      case Type::choice_list: {
        json list = v;
        if (v.is_string()) list = json::array({v});  // one format may be given alone
        if (!list.is_array())
          fail("request.type", fmt::format("{}: expected an array of strings, got {}", shown(path), type_name(v)), path);
        if (list.size() > 16) fail("request.limit", shown(path) + ": at most 16 entries", path);
        json out = json::array();
        for (const auto& e : list) {
          const std::string& c = text(s, path, e);
          if (std::find(s.choices.begin(), s.choices.end(), c) == s.choices.end())
            fail("request.value",
                 fmt::format("{}: unknown value '{}' (one of: {})", shown(path), c.substr(0, 32), choices_text(s.choices)),
                 path);
          if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
        }
        if (out.empty()) fail("request.value", shown(path) + ": empty list", path);
        return out;
      }
      case Type::base64: {
        const std::string& b = text(s, path, v, std::numeric_limits<std::size_t>::max());
        auto bytes = decode_base64(b, ctx_.limits.max_ui_bytes);
        if (!bytes) fail(bytes.error().code, shown(path) + ": " + bytes.error().message, path);
        if (bytes->empty()) fail("request.value", shown(path) + ": empty (no PNG data)", path);
        r_.ui_png = std::move(*bytes);
        return fmt::format("{} bytes", r_.ui_png.size());  // the bytes travel in FrameRequest::ui_png
      }
      case Type::scene: return scene(s, path, v);
    }
    return v;
  }

  bool accepted_alias(const Setting& s, const std::string& c) const {
    return s.path == "display.mode" ? parse_mode(c).has_value()
           : s.path == "display.range" ? parse_range(c).has_value()
           : s.path == "display.sdr_curve" ? parse_sdr_curve(c).has_value()
                                           : false;
  }
  json canonical_choice(const Setting& s, const std::string& c) const {
    if (s.path == "display.mode") return std::string(to_string(*parse_mode(c)));
    if (s.path == "display.range") return std::string(to_string(*parse_range(c)));
    if (s.path == "display.sdr_curve") return std::string(to_string(*parse_sdr_curve(c)));
    return c;
  }

  const std::string& text(const Setting& s, const std::string& path, const json& v,
                          std::size_t max = 0) {
    if (!v.is_string()) fail("request.type", fmt::format("{}: expected a string, got {}", shown(path), type_name(v)), path);
    const auto& str = v.get_ref<const std::string&>();
    if (str.size() > (max ? max : s.max_length))
      fail("request.limit", fmt::format("{}: longer than {} bytes", shown(path), max ? max : s.max_length), path);
    if (str.find('\0') != std::string::npos) fail("request.value", shown(path) + ": contains a NUL byte", path);
    return str;
  }

  std::filesystem::path resolve(const std::string& requested, const std::string& path) {
    if (!ctx_.resolve_path) fail("path.forbidden", shown(path) + ": this front end takes no file names", path);
    auto p = ctx_.resolve_path(requested, path);
    if (!p) {
      Error e = p.error();
      if (e.field.empty()) e.field = path;
      throw Fail{e};
    }
    return *p;
  }

  // A built-in name, a file (.gltf, .glb, .json) or an inline JSON scene object.
  json scene(const Setting& s, const std::string& path, const json& v) {
    if (v.is_object()) {
      r_.scene = {SceneRef::Kind::inline_json, {}, {}, v};
      if (auto it = v.find("lights"); it != v.end() && it->is_array() &&
                                      it->size() > std::size_t(ctx_.limits.max_lights))
        fail("request.limit", fmt::format("scene.lights: {} lights, at most {}", it->size(), ctx_.limits.max_lights),
             "scene.lights");
      return v;
    }
    const std::string& name = text(s, path, v);
    if (name.empty()) fail("request.value", shown(path) + ": empty name", path);
    const auto ext = std::filesystem::path(name).extension().string();
    if (ext == ".gltf" || ext == ".glb" || ext == ".json") {
      const auto p = resolve(name, path);
      r_.scene = {SceneRef::Kind::file, {}, p, {}};
      return p.string();
    }
    r_.scene = {SceneRef::Kind::builtin, name, {}, {}};
    return name;
  }

  const ParseContext& ctx_;
  FrameRequest& r_;
};

// ---- rules that tie settings together ------------------------------------------------

class Rules {
 public:
  Rules(const ParseContext& ctx, FrameRequest& r) : ctx_(ctx), r_(r) {}

  void check() {
    size();
    display();
    if (ctx_.source != Source::pattern) {
      tone();
      exposure();
      ui();
      grade();
    } else {
      pattern();
    }
    outputs();
  }

 private:
  std::string shown(std::string_view path) const { return label(path, ctx_.spelling); }

  void size() {
    if (ctx_.source == Source::encode) return;
    const auto& l = ctx_.limits;
    const auto w = r_.integer("width"), h = r_.integer("height");
    // A daemon may be configured below the table's defaults: say which it was.
    auto over = [&](const char* path, std::int64_t v, std::int64_t max) {
      fail("request.limit",
           fmt::format("{}: {}{} is more than the limit {}{}", shown(path), r_.has(path) ? "" : "the default ", v, max,
                       r_.has(path) ? "" : ": give it"),
           path);
    };
    if (w > l.max_width) over("width", w, l.max_width);
    if (h > l.max_height) over("height", h, l.max_height);
    if (w * h > l.max_pixels)
      fail("request.limit", fmt::format("width x height: {} pixels, at most {}", w * h, l.max_pixels), "width");
    if (ctx_.source == Source::render && r_.integer("samples") > l.max_samples)
      over("samples", r_.integer("samples"), l.max_samples);
  }

  // Levels are checked here when no display is consulted (a connector or an EDID is only
  // read when the frame is made; the levels resolver checks those then).
  void display() {
    if (!r_.is_null("display.connector") || !r_.is_null("display.edid") || !r_.is_null("display.profile")) return;
    const Mode mode = parse_mode(r_.text("display.mode")).value_or(Mode::hdr10);
    LevelSettings req = request_levels(r_);
    auto t = resolve_target(mode, {}, req);
    if (!t) {
      Error e = t.error();
      e.code = "request.value";
      e.message = one_line(shown(e.field) + ": " + e.message);
      throw Fail{e};
    }
  }

  void tone() {
    const std::string name = r_.text("tone.curve");
    const auto* info = tonemap::find_curve(name);
    if (!info) {
      std::string names;
      for (const auto& c : tonemap::curves()) names += (names.empty() ? "" : ", ") + std::string(c.name);
      fail("request.value", fmt::format("{}: unknown tone curve '{}' (one of: {})", shown("tone.curve"), name.substr(0, 64), names),
           "tone.curve");
    }
    tonemap::ParamValues params;
    for (const auto& [k, v] : r_.at("tone.params").items()) params[k] = v.get<double>();
    if (auto ok = tonemap::resolve_params(*info, params); !ok) {
      Error e = ok.error();
      e.code = "request.value";
      e.field = "tone.params";
      e.message = one_line(shown("tone.params") + ": " + e.message);
      throw Fail{e};
    }
    const std::string apply = r_.text("tone.apply");
    if (!apply.empty() && !info->scalar && apply != "rgb")
      fail("request.value",
           fmt::format("{}: tone curve '{}' is an RGB operator; it cannot be applied {}", shown("tone.apply"), info->name,
                       apply),
           "tone.apply");
  }

  void exposure() {
    if (r_.number("exposure.ignore_dark_fraction") + r_.number("exposure.ignore_bright_fraction") >= 1.0)
      fail("request.value", "exposure: ignore_dark_fraction + ignore_bright_fraction must be below 1",
           "exposure.ignore_bright_fraction");
    if (ctx_.source == Source::encode && r_.text("exposure.mode") == "light" && r_.is_null("exposure.illuminance_lux"))
      fail("request.value",
           fmt::format("{} light needs {} for an EXR input (a render knows its lights)", shown("exposure.mode"),
                       shown("exposure.illuminance_lux")),
           "exposure.illuminance_lux");
  }

  void ui() {
    const bool path = r_.has("ui.path"), upload = r_.has("ui.png_base64");
    if (path && upload) fail("request.conflict", "ui: give path or png_base64, not both", "ui.path");
    if (path || upload) return;
    for (const char* k : {"ui.premultiplied", "ui.x", "ui.y", "ui.scale", "ui.blend", "ui.dim"})
      if (r_.has(k))
        fail("request.value", fmt::format("{}: needs {} (a PNG)", shown(k), shown("ui.path")), "ui.path");
  }

  void grade() {
    const bool lut = r_.has("grade.lut"), look = r_.has("grade.ocio_look"), display = r_.has("grade.ocio_display"),
               view = r_.has("grade.ocio_view");
    if (display != view)
      fail("request.value", fmt::format("{} and {} go together", shown("grade.ocio_display"), shown("grade.ocio_view")),
           display ? "grade.ocio_view" : "grade.ocio_display");
    if (r_.has("grade.shaper")) {
      if (auto spec = lut::parse_shaper_spec(r_.text("grade.shaper")); !spec)
        fail("request.value", shown("grade.shaper") + ": " + spec.error().message, "grade.shaper");
    }
    if (lut || look || display) return;
    for (const char* k : {"grade.shaper", "grade.placement", "grade.trilinear", "grade.ocio_config"})
      if (r_.has(k))
        fail("request.value", fmt::format("{}: needs {} (or an OpenColorIO look or display/view)", shown(k),
                                          shown("grade.lut")),
             k);
  }

  void pattern() {
    const std::string name = r_.text("pattern");
    if (name.empty()) fail("request.value", fmt::format("pattern: required (one of: {})", pattern_names()), "pattern");
    const PatternEntry* entry = find_pattern_entry(name);
    if (!entry)
      fail("request.value", fmt::format("pattern: unknown pattern '{}' (one of: {})", name.substr(0, 64), pattern_names()),
           "pattern");
    for (const auto& path : r_.given)
      if (path.rfind("params.", 0) == 0 && !takes_param(*entry, path))
        fail("request.unknown_field",
             fmt::format("{}: not a parameter of pattern {} (its parameters: {})", shown(path), entry->name,
                         param_names(*entry)),
             path);
    if (r_.has("params.steps")) {
      const auto steps = r_.integer("params.steps");
      if (steps < entry->min_steps || steps > entry->max_steps)
        fail("request.value", fmt::format("{}: {} is outside [{}, {}] for {}", shown("params.steps"), steps,
                                          entry->min_steps, entry->max_steps, entry->name),
             "params.steps");
    }
    // A display's mode is known only when it is read: the job checks those.
    if (entry->modes.empty() || !r_.is_null("display.connector") || !r_.is_null("display.edid")) return;
    const Mode mode = parse_mode(r_.text("display.mode")).value_or(Mode::hdr10);
    if (std::find(entry->modes.begin(), entry->modes.end(), mode) != entry->modes.end()) return;
    std::string modes;
    for (Mode m : entry->modes) modes += (modes.empty() ? "" : ", ") + std::string(to_string(m));
    fail("request.value",
         fmt::format("{}: pattern {} exists for {} only, not {}", shown("display.mode"), entry->name, modes, to_string(mode)),
         "display.mode");
  }

  void outputs() {
    if (r_.has("name")) {
      const std::string n = r_.text("name");
      const bool ok = !n.empty() && n.size() <= 100 && n[0] != '.' &&
                      std::all_of(n.begin(), n.end(), [](unsigned char c) {
                        return std::isalnum(c) || c == '.' || c == '_' || c == '-';
                      });
      if (!ok)
        fail("request.value", "name: 1-100 characters of A-Z a-z 0-9 . _ -, not starting with '.'", "name");
      // Per file, not per name: a name may not end in what makes its files another's.
      if (const auto ending = colliding_name_ending(n))
        fail("name.collision",
             fmt::format("name: '{}' ends in '{}', so its files could be those of a job named '{}' (its per-frame or "
                         "metadata files); choose a name without it",
                         n, *ending, n.substr(0, n.size() - ending->size())),
             "name");
    }
    if (r_.has("timeout_s") && r_.number("timeout_s") > ctx_.limits.max_request_seconds)
      fail("request.limit", fmt::format("timeout_s: {:g} s is more than the limit {:g} s", r_.number("timeout_s"),
                                        ctx_.limits.max_request_seconds),
           "timeout_s");
    if (!r_.has("formats")) return;
    if (ctx_.reach == Reach::daemon && !r_.boolean("dump"))
      fail("request.conflict", "formats: only meaningful with \"dump\": true (the reply's format is the Accept header's)",
           "formats");
    const auto formats = r_.list("formats");
    auto has = [&](std::string_view f) { return std::find(formats.begin(), formats.end(), f) != formats.end(); };
    if (has("scene-exr") && ctx_.source != Source::render)
      fail("request.value", shown("formats") + ": scene-exr is the scene light of a render", "formats");
    if (has("png") && r_.is_null("display.connector") && r_.is_null("display.edid") &&
        !mode_info(parse_mode(r_.text("display.mode")).value_or(Mode::hdr10)).png)
      fail("request.value", shown("formats") + ": scrgb has no PNG form (FP16 linear): use exr or raw", "formats");
  }

  const ParseContext& ctx_;
  FrameRequest& r_;
};

void fill_defaults(FrameRequest& r, const ParseContext& ctx) {
  for (const auto& s : settings()) {
    if (!s.takes(r.source) || r.values.count(s.path)) continue;
    if (s.sequence && !ctx.sequence) continue;
    if (s.reach == Reach::cli && ctx.reach == Reach::daemon) continue;
    if (s.reach == Reach::daemon && ctx.reach == Reach::cli) continue;
    nlohmann::json v = s.default_value();
    if (s.type == Type::number && v.is_number()) v = v.get<double>();  // 0 and 0.0 are one value
    r.values.emplace(std::string(s.path), std::move(v));
  }
  if (r.source == Source::render && !r.given.count("scene")) r.scene = {SceneRef::Kind::builtin, r.text("scene"), {}, {}};
}

// A display given as a string is its connector ("display": "auto").
json normalise(const json& body) {
  json b = body;
  if (auto it = b.find("display"); it != b.end() && it->is_string()) *it = json{{"connector", *it}};
  return b;
}

}  // namespace

// ---- FrameRequest ----------------------------------------------------------------------

const nlohmann::json& FrameRequest::at(std::string_view path) const {
  auto it = values.find(path);
  if (it == values.end()) throw std::logic_error("setting '" + std::string(path) + "' is not part of this request");
  if (!read.count(path)) read.emplace(path);
  return it->second;
}

std::optional<double> FrameRequest::optional_number(std::string_view path) const {
  const json& v = at(path);
  return v.is_null() ? std::nullopt : std::optional<double>(v.get<double>());
}

std::string FrameRequest::text(std::string_view path) const {
  const json& v = at(path);
  return v.is_null() ? std::string() : v.get<std::string>();
}

std::vector<std::string> FrameRequest::list(std::string_view path) const {
  const json& v = at(path);
  return v.is_null() ? std::vector<std::string>{} : v.get<std::vector<std::string>>();
}

nlohmann::json FrameRequest::canonical() const {
  json j = json::object();
  j["source"] = to_string(source);
  for (const auto& [path, v] : values) {
    std::string p = path;
    std::replace(p.begin(), p.end(), '.', '/');
    j[json::json_pointer("/" + p)] = v;
  }
  if (!ui_png.empty())  // the upload's digest, so two uploads differ
    j["ui"]["png_xxh3_128"] =
        io::content_digest(std::string_view(reinterpret_cast<const char*>(ui_png.data()), ui_png.size()));
  return j;
}

LevelSettings request_levels(const FrameRequest& r) {
  LevelSettings l;
  l.peak_nits = r.optional_number("display.peak_nits");
  l.black_nits = r.optional_number("display.black_nits");
  l.paper_white_nits = r.optional_number("display.paper_white_nits");
  l.ui_white_nits = r.optional_number("display.ui_white_nits");
  l.sdr_white_nits = r.optional_number("display.sdr_white_nits");
  // Range and SDR curve have static defaults, but only a given one overrides the display's.
  const std::string range = r.text("display.range"), sdr_curve = r.text("display.sdr_curve"),
                    sdr_eotf = r.text("display.sdr_content_eotf"), inverse = r.text("ui.inverse_tonemap");
  if (r.has("display.sdr_content_eotf")) l.sdr_content_eotf = parse_sdr_eotf(sdr_eotf);
  if (r.has("ui.inverse_tonemap")) l.sdr_inverse_tonemap = parse_inverse_tonemap(inverse);
  if (r.has("display.range")) l.range = parse_range(range);
  if (r.has("display.sdr_curve")) l.sdr_curve = parse_sdr_curve(sdr_curve);
  if (!r.is_null("display.bits")) l.bits = static_cast<int>(r.integer("display.bits"));
  return l;
}

// ---- parsing -------------------------------------------------------------------------------

Result<FrameRequest> parse_request_json(const nlohmann::json& body, const ParseContext& ctx) {
  try {
    if (!body.is_object())
      return make_error("request.type", fmt::format("request: expected a JSON object, got {}", type_name(body)), "");
    FrameRequest r;
    r.source = ctx.source;
    r.sequence = ctx.sequence;
    Parser(ctx, r).walk(normalise(body), "");
    fill_defaults(r, ctx);
    Rules(ctx, r).check();
    return r;
  } catch (const Fail& f) {
    return f.error;
  } catch (const nlohmann::json::exception& e) {
    return make_error("request.type", one_line(std::string("request: ") + e.what()), "");
  }
}

io::JsonBounds request_json_bounds(const Limits& limits, std::string_view what) {
  return io::JsonBounds{limits.max_body_bytes, limits.max_json_depth, what, "request."};
}

Result<nlohmann::json> parse_json_object_bounded(std::string_view text, const Limits& limits, std::string_view what) {
  auto doc = io::parse_json_bounded(text, request_json_bounds(limits, what));
  if (!doc) return doc.error();
  if (!doc->is_object())
    return make_error("request.type", fmt::format("{}: expected a JSON object, got {}", what, type_name(*doc)), "");
  return doc;
}

// Size, NUL bytes, UTF-8 and nesting depth are bounded while the text is read (a deep
// document is never built), and a number beyond double's range names its field.
Result<FrameRequest> parse_request(std::string_view body, const ParseContext& ctx) {
  auto doc = parse_json_object_bounded(body, ctx.limits);
  if (!doc) return doc.error();
  return parse_request_json(*doc, ctx);
}

// ---- the other spellings ----------------------------------------------------------------

std::string label(std::string_view path, Spelling spelling) {
  const Setting* s = find_setting(path);
  if (!s) {
    // "tone.params.knee": label the map and add the key.
    const auto dot = path.rfind('.');
    if (dot != std::string_view::npos && (s = find_setting(path.substr(0, dot))) && s->type == Type::number_map)
      return spelling == Spelling::cli ? fmt::format("{} {}", s->flag, path.substr(dot + 1)) : std::string(path);
    return std::string(path);
  }
  if (spelling == Spelling::cli && !s->flag.empty()) return std::string(s->flag);
  if (spelling == Spelling::query && !s->query.empty()) return std::string(s->query);
  return std::string(s->path);
}

namespace {

// Strict decimal numbers (std::from_chars: no leading '+', no spaces, no "0x").
std::optional<double> to_number(std::string_view text) {
  double v = 0;
  if (text.empty()) return std::nullopt;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return v;
}

// RFC 3629: no overlong forms, no surrogates, nothing above U+10FFFF.
bool valid_utf8(std::string_view s) {
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      ++i;
      continue;
    }
    const int n = (c & 0xE0) == 0xC0 ? 1 : (c & 0xF0) == 0xE0 ? 2 : (c & 0xF8) == 0xF0 ? 3 : 0;
    if (n == 0 || i + static_cast<std::size_t>(n) >= s.size()) return false;
    std::uint32_t cp = c & (0x3F >> n);
    for (int k = 1; k <= n; ++k) {
      const auto d = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    constexpr std::uint32_t kMin[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += static_cast<std::size_t>(n) + 1;
  }
  return true;
}

// One textual value (a flag's or a query parameter's) as the JSON value of its setting.
Result<json> from_text(const Setting& s, std::string_view text, const std::string& shown) {
  auto bad = [&](std::string what) {
    return make_error("request.type", one_line(fmt::format("{}: {}", shown, what)), std::string(s.path));
  };
  switch (s.type) {
    case Type::number:
    case Type::integer: {
      const auto v = to_number(text);
      if (!v) return bad(fmt::format("'{}' is not a number", text.substr(0, 64)));
      return json(*v);
    }
    case Type::boolean:
      if (text == "true" || text == "1" || text.empty()) return json(true);
      if (text == "false" || text == "0") return json(false);
      return bad("expected true or false");
    case Type::vec3: {
      json out = json::array();
      std::size_t pos = 0;
      for (int i = 0; i < 3; ++i) {
        const auto end = i < 2 ? text.find(',', pos) : text.size();
        const auto v = end == std::string_view::npos ? std::nullopt : to_number(text.substr(pos, end - pos));
        if (!v) return bad("expected X,Y,Z");
        out.push_back(*v);
        pos = end + 1;
      }
      return out;
    }
    case Type::choice_list: {
      json out = json::array();
      for (std::size_t pos = 0; pos <= text.size();) {
        const auto comma = std::min(text.find(',', pos), text.size());
        if (comma > pos) out.push_back(std::string(text.substr(pos, comma - pos)));
        pos = comma + 1;
      }
      return out;
    }
    case Type::number_map: {
      const auto eq = text.find('=');
      if (eq == std::string_view::npos || eq == 0) return bad(fmt::format("'{}' is not NAME=VALUE", text.substr(0, 64)));
      const auto v = to_number(text.substr(eq + 1));
      if (!v) return bad(fmt::format("'{}' has no numeric value", text.substr(0, 64)));
      return json{{std::string(text.substr(0, eq)), *v}};
    }
    default: return json(std::string(text));
  }
}

void put(json& doc, std::string_view path, json value) {
  std::string p(path);
  std::replace(p.begin(), p.end(), '.', '/');
  const json::json_pointer ptr("/" + p);
  if (doc.contains(ptr) && doc[ptr].is_object() && value.is_object()) doc[ptr].update(value);  // --tonemap-param, repeated
  else if (doc.contains(ptr) && doc[ptr].is_array() && value.is_array()) doc[ptr].insert(doc[ptr].end(), value.begin(), value.end());
  else doc[ptr] = std::move(value);
}

}  // namespace

Result<nlohmann::json> cli_to_request_json(const std::vector<std::pair<std::string, std::string>>& flags) {
  json doc = json::object();
  for (const auto& [flag, text] : flags) {
    const Composite* c = nullptr;  // (a loop, not a lambda: clang 14 cannot capture a structured binding)
    for (const auto& candidate : composites())
      if (candidate.flag == flag) {
        c = &candidate;
        break;
      }
    if (c) {
      std::string why;
      json frag = c->expand(text, &why);
      if (frag.is_null()) return make_error("request.type", one_line(fmt::format("{}: {}", flag, why)), std::string(c->paths[0]));
      doc.merge_patch(frag);
      continue;
    }
    const Setting* s = nullptr;
    bool negated = false;
    for (const auto& e : settings())
      if (e.flag == flag) s = &e, negated = flag.rfind("--no-", 0) == 0;
    if (!s) return make_error("cli.option", "unknown option " + flag, flag);
    auto v = negated ? Result<json>(json(false)) : from_text(*s, text, flag);
    if (!v) return v.error();
    put(doc, s->path, std::move(*v));
  }
  return doc;
}

Result<nlohmann::json> query_to_request_json(const std::vector<std::pair<std::string, std::string>>& query) {
  json doc = json::object();
  // A name quoted in an error: its first 64 bytes, cut at a character boundary so that it
  // stays UTF-8 (the error body is JSON).
  auto head = [](const std::string& k) {
    std::size_t n = std::min<std::size_t>(k.size(), 64);
    while (n > 0 && n < k.size() && (static_cast<unsigned char>(k[n]) & 0xC0) == 0x80) --n;
    return k.substr(0, n);
  };
  for (const auto& [key, value] : query) {
    const std::string shown = one_line(head(key));
    if (!valid_utf8(key) || !valid_utf8(value))
      return make_error("request.value", fmt::format("query parameter '{}': not valid UTF-8", valid_utf8(key) ? shown : "?"),
                        valid_utf8(key) ? head(key) : "");
    const Setting* s = nullptr;
    for (const auto& e : settings())
      if (e.query == key) s = &e;
    if (!s) return make_error("request.unknown_field", fmt::format("query parameter '{}': unknown", shown), head(key));
    std::string p(s->path);
    std::replace(p.begin(), p.end(), '.', '/');
    if (doc.contains(json::json_pointer("/" + p)))
      return make_error("request.conflict", fmt::format("query parameter '{}': given twice", shown), std::string(s->path));
    auto v = from_text(*s, value, shown);
    if (!v) return v.error();
    put(doc, s->path, std::move(*v));
  }
  return doc;
}

Result<std::vector<std::uint8_t>> decode_base64(std::string_view text, std::size_t max_bytes) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  while (!text.empty() && text.back() == '=') text.remove_suffix(1);
  if (text.size() % 4 == 1) return make_error("request.value", "invalid base64 length");
  if (text.size() / 4 * 3 > max_bytes + 2)
    return make_error("request.limit", fmt::format("decoded data exceeds {} bytes", max_bytes));
  std::vector<std::uint8_t> out;
  out.reserve(text.size() / 4 * 3 + 2);
  std::uint32_t acc = 0;
  int bits = 0;
  for (char c : text) {
    const int v = value(c);
    if (v < 0) return make_error("request.value", "invalid base64 character");
    acc = (acc << 6) | std::uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(std::uint8_t((acc >> bits) & 0xff));
    }
  }
  if (out.size() > max_bytes) return make_error("request.limit", fmt::format("decoded data exceeds {} bytes", max_bytes));
  return out;
}

}  // namespace hdrd::job

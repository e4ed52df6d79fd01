#include "daemon/request.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "daemon/input_bounds.hpp"
#include "daemon/paths.hpp"
#include "daemon/pattern_catalogue.hpp"
#include "daemon/text.hpp"
#include "encode/tone/tonemap.hpp"

namespace hdrd::daemon {
namespace {

using nlohmann::json;

// Inside the parser a failure unwinds to parse_request_json(), the one place that turns
// it back into a Result (exceptions inside, one boundary).
struct Fail {
  Error error;
};
[[noreturn]] void fail(std::string code, std::string message, std::string field) {
  throw Fail{make_error(std::move(code), one_line(message), std::move(field))};
}

std::string join(const std::string& prefix, std::string_view key) {
  return prefix.empty() ? std::string(key) : prefix + "." + std::string(key);
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

// Reads the fields of one JSON object, each with its type and range; finish() refuses any
// field that nothing read (unknown fields are errors, so that typos are never ignored).
class Fields {
 public:
  Fields(const json& obj, std::string prefix) : obj_(obj), prefix_(std::move(prefix)) {
    if (!obj_.is_object())
      fail("request.type", fmt::format("{}: expected an object, got {}", name(), type_name(obj_)), name());
  }

  const json* get(std::string_view key) {
    seen_.insert(std::string(key));
    auto it = obj_.find(key);
    if (it == obj_.end()) return nullptr;
    return &*it;
  }
  bool has(std::string_view key) const { return obj_.contains(key); }

  std::optional<double> number(std::string_view key, double min, double max) {
    const json* v = get(key);
    if (!v) return std::nullopt;
    const std::string f = join(prefix_, key);
    if (!v->is_number()) fail("request.type", fmt::format("{}: expected a number, got {}", f, type_name(*v)), f);
    const double d = v->get<double>();
    if (!std::isfinite(d)) fail("request.value", f + ": must be a finite number", f);
    if (d < min || d > max) fail("request.value", fmt::format("{}: {} is outside [{}, {}]", f, d, min, max), f);
    return d;
  }

  std::optional<std::int64_t> integer(std::string_view key, std::int64_t min, std::int64_t max,
                                      std::string_view limit_code = "request.value") {
    const json* v = get(key);
    if (!v) return std::nullopt;
    const std::string f = join(prefix_, key);
    if (!v->is_number()) fail("request.type", fmt::format("{}: expected an integer, got {}", f, type_name(*v)), f);
    std::int64_t i = 0;
    if (v->is_number_integer()) {
      if (v->is_number_unsigned() && v->get<std::uint64_t>() > std::uint64_t(std::numeric_limits<std::int64_t>::max()))
        fail(std::string(limit_code), fmt::format("{}: {} is larger than {}", f, v->get<std::uint64_t>(), max), f);
      i = v->get<std::int64_t>();
    } else {
      const double d = v->get<double>();
      if (!std::isfinite(d) || d != std::floor(d))
        fail("request.type", fmt::format("{}: expected an integer, got {}", f, d), f);
      if (std::fabs(d) > 9e15) fail(std::string(limit_code), fmt::format("{}: {} is larger than {}", f, d, max), f);
      i = static_cast<std::int64_t>(d);
    }
    if (i < min || i > max)
      fail(std::string(limit_code), fmt::format("{}: {} is outside [{}, {}]", f, i, min, max), f);
    return i;
  }

  std::optional<std::string> string(std::string_view key, std::size_t max_len = 256) {
    const json* v = get(key);
    if (!v) return std::nullopt;
    const std::string f = join(prefix_, key);
    if (!v->is_string()) fail("request.type", fmt::format("{}: expected a string, got {}", f, type_name(*v)), f);
    const auto& s = v->get_ref<const std::string&>();
    if (s.size() > max_len) fail("request.limit", fmt::format("{}: longer than {} bytes", f, max_len), f);
    return s;
  }

  std::optional<bool> boolean(std::string_view key) {
    const json* v = get(key);
    if (!v) return std::nullopt;
    const std::string f = join(prefix_, key);
    if (!v->is_boolean()) fail("request.type", fmt::format("{}: expected true or false, got {}", f, type_name(*v)), f);
    return v->get<bool>();
  }

  std::optional<std::array<double, 3>> vec3(std::string_view key, double limit = 1e6) {
    const json* v = get(key);
    if (!v) return std::nullopt;
    const std::string f = join(prefix_, key);
    if (!v->is_array() || v->size() != 3)
      fail("request.type", fmt::format("{}: expected an array of 3 numbers, got {}", f, type_name(*v)), f);
    std::array<double, 3> out{};
    for (int i = 0; i < 3; ++i) {
      const json& e = (*v)[i];
      if (!e.is_number()) fail("request.type", fmt::format("{}[{}]: expected a number", f, i), f);
      out[i] = e.get<double>();
      if (!std::isfinite(out[i]) || std::fabs(out[i]) > limit)
        fail("request.value", fmt::format("{}[{}]: must be finite and within +-{}", f, i, limit), f);
    }
    return out;
  }

  // Fails on the first field nobody asked for.
  void finish() const {
    for (auto it = obj_.begin(); it != obj_.end(); ++it)
      if (!seen_.count(it.key())) {
        const std::string f = join(prefix_, it.key());
        fail("request.unknown_field", fmt::format("{}: unknown field", f), f);
      }
  }

  std::string field(std::string_view key) const { return join(prefix_, key); }
  std::string name() const { return prefix_.empty() ? "request" : prefix_; }

 private:
  const json& obj_;
  std::string prefix_;
  std::set<std::string, std::less<>> seen_;
};

// Parses a name with one of the encode module's parse_* functions, naming the choices
// on failure.
template <class Parse>
void check_choice(const std::optional<std::string>& value, std::string field, Parse parse, std::string_view choices) {
  if (value && !parse(*value))
    fail("request.value", fmt::format("{}: unknown value '{}' (one of: {})", field, *value, choices), field);
}

std::filesystem::path resolve(const ParseContext& ctx, std::string_view requested, const std::string& field) {
  auto r = resolve_in_root(ctx.asset_root, requested, field);
  if (!r) throw Fail{r.error()};
  return *r;
}

void parse_scene(Fields& top, Request& r, const ParseContext& ctx) {
  const int given = int(top.has("scene")) + int(top.has("scene_file")) + int(top.has("gltf"));
  if (given > 1) fail("request.conflict", "scene, scene_file and gltf are alternatives: give one", "scene");
  if (const json* s = top.get("scene")) {
    if (s->is_string()) {
      const auto name = *top.string("scene", 64);
      if (name.empty()) fail("request.value", "scene: empty name", "scene");
      r.scene = {SceneSpec::Kind::builtin, name, {}, {}};
    } else if (s->is_object()) {
      r.scene.kind = SceneSpec::Kind::inline_json;
      r.scene.inline_scene = *s;
      if (auto it = s->find("lights"); it != s->end() && it->is_array() &&
                                       it->size() > std::size_t(ctx.limits.max_lights))
        fail("request.limit", fmt::format("scene.lights: {} lights, at most {}", it->size(), ctx.limits.max_lights),
             "scene.lights");
    } else {
      fail("request.type", fmt::format("scene: expected a scene name or a JSON scene object, got {}", type_name(*s)),
           "scene");
    }
  } else if (auto f = top.string("scene_file", 4096)) {
    r.scene = {SceneSpec::Kind::scene_file, {}, {}, resolve(ctx, *f, "scene_file")};
  } else if (auto g = top.string("gltf", 4096)) {
    r.scene = {SceneSpec::Kind::gltf, {}, {}, resolve(ctx, *g, "gltf")};
  } else {
    r.scene = {SceneSpec::Kind::builtin, ctx.defaults.scene, {}, {}};
  }
}

void parse_camera(Fields& top, Request& r) {
  const json* c = top.get("camera");
  if (!c) return;
  Fields f(*c, "camera");
  r.camera.position = f.vec3("position");
  r.camera.target = f.vec3("target");
  r.camera.fov_y_deg = f.number("fov_y_deg", 1.0, 179.0);
  f.finish();
}

void parse_size(Fields& top, Request& r, const ParseContext& ctx) {
  const auto& lim = ctx.limits;
  r.width = int(top.integer("width", 1, lim.max_width, "request.limit").value_or(ctx.defaults.width));
  r.height = int(top.integer("height", 1, lim.max_height, "request.limit").value_or(ctx.defaults.height));
  if (std::int64_t(r.width) * r.height > lim.max_pixels)
    fail("request.limit", fmt::format("width x height: {} pixels, at most {}", std::int64_t(r.width) * r.height,
                                      lim.max_pixels),
         "width");
  r.samples = int(top.integer("samples", 1, lim.max_samples, "request.limit").value_or(ctx.defaults.samples));
}

// REFERENCE.md §1.8: the mode's defaults, then the request's values. SDR paper white
// follows peak; UI and SDR white follow paper white unless given.
void parse_display(Fields& top, Request& r, const ParseContext& ctx) {
  const json* d = top.get("display");
  if (!d) return;
  if (d->is_string()) {
    if (*d != "auto") fail("request.value", "display: a display object or the string \"auto\"", "display");
    r.display.auto_detect = true;
    return;
  }
  Fields f(*d, "display");
  const auto mode_name = f.string("mode", 32);
  check_choice(mode_name, "display.mode", parse_mode, "hdr10, hlg, scrgb, sdr, sdr-bt1886");
  const Mode mode = mode_name ? *parse_mode(*mode_name) : Mode::hdr10;
  DisplayTarget t = default_target(mode);
  if (const auto e = f.string("edid", 4096)) r.display.edid_path = resolve(ctx, *e, "display.edid");
  if (const auto a = f.boolean("auto")) r.display.auto_detect = *a;
  const auto peak = f.number("peak_nits", 1e-3, 10000);
  const auto black = f.number("black_nits", 0, 10000);
  const auto paper = f.number("paper_white_nits", 1e-3, 10000);
  const auto ui = f.number("ui_white_nits", 1e-3, 10000);
  const auto sdr = f.number("sdr_white_nits", 1e-3, 10000);
  for (const char* k : {"mode", "peak_nits", "black_nits", "paper_white_nits", "ui_white_nits", "sdr_white_nits", "range",
                        "sdr_curve", "bits"})
    if (f.has(k)) r.display.given.push_back(k);
  if (peak) t.peak_nits = *peak;
  if (black) t.black_nits = *black;
  const bool sdr_mode = mode == Mode::sdr || mode == Mode::sdr_bt1886;
  t.paper_white_nits = paper ? *paper : (sdr_mode ? t.peak_nits : t.paper_white_nits);
  t.ui_white_nits = ui ? *ui : t.paper_white_nits;
  t.sdr_white_nits = sdr ? *sdr : t.paper_white_nits;
  const auto range = f.string("range", 16);
  check_choice(range, "display.range", parse_range, "full, narrow");
  if (range) t.range = *parse_range(*range);
  const auto curve = f.string("sdr_curve", 16);
  check_choice(curve, "display.sdr_curve", parse_sdr_curve, "srgb, gamma22");
  if (curve) t.sdr_curve = *parse_sdr_curve(*curve);
  if (const auto bits = f.integer("bits", 8, 16)) t.bits = int(*bits);
  f.finish();
  t.source = "request";
  if (auto v = validate(t); !v) {
    Error e = v.error();
    if (!e.field.empty() && e.field.rfind("display.", 0) != 0) e.field = "display." + e.field;
    e.code = "request.value";
    throw Fail{e};
  }
  r.display.target = t;
}

void parse_tone(Fields& top, Request& r) {
  const json* t = top.get("tone");
  if (!t) return;
  Fields f(*t, "tone");
  r.tone.curve = f.string("curve", 64).value_or("");
  const auto apply = f.string("apply", 32);
  check_choice(apply, "tone.apply", tonemap::parse_apply, "per-channel, max-rgb, luminance, rgb");
  r.tone.apply = apply.value_or("");
  if (const json* p = f.get("params")) {
    Fields pf(*p, "tone.params");
    if (p->size() > 32) fail("request.limit", "tone.params: at most 32 parameters", "tone.params");
    for (auto it = p->begin(); it != p->end(); ++it) {
      if (it.key().size() > 64) fail("request.limit", "tone.params: parameter name too long", "tone.params");
      r.tone.params[it.key()] = *pf.number(it.key(), -1e9, 1e9);
    }
  }
  f.finish();
}

void parse_exposure(Fields& top, Request& r) {
  auto& e = r.exposure;
  const auto top_comp = top.number("exposure_comp_ev", -30, 30);
  if (const json* x = top.get("exposure")) {
    Fields f(*x, "exposure");
    const auto mode = f.string("mode", 32);
    check_choice(mode, "exposure.mode", exposure::parse_mode, "manual, camera, log-average, histogram, light");
    if (mode) e.mode = *exposure::parse_mode(*mode);
    r.exposure_mode_given = mode.has_value();
    if (auto v = f.number("compensation_ev", -30, 30)) {
      if (top_comp && *top_comp != *v)
        fail("request.conflict", "exposure_comp_ev and exposure.compensation_ev disagree: give one",
             "exposure.compensation_ev");
      e.compensation_ev = *v;
    }
    if (auto v = f.number("gain", 1e-9, 1e9)) e.gain = *v;
    e.ev100 = f.number("ev100", -30, 40);
    // As on the command line: an EV100 without a mode means camera exposure.
    if (e.ev100 && !mode) {
      e.mode = exposure::Mode::camera;
      r.exposure_mode_given = true;
    }
    const auto aperture = f.number("aperture_f", 0.5, 128);
    const auto aperture_alias = f.number("aperture", 0.5, 128);
    if (aperture && aperture_alias) fail("request.conflict", "exposure: give aperture_f or aperture, not both", "exposure.aperture");
    if (aperture || aperture_alias) e.aperture_f = aperture ? *aperture : *aperture_alias;
    const auto shutter = f.number("shutter_s", 1e-6, 3600);
    const auto shutter_alias = f.number("shutter", 1e-6, 3600);
    if (shutter && shutter_alias) fail("request.conflict", "exposure: give shutter_s or shutter, not both", "exposure.shutter");
    if (shutter || shutter_alias) e.shutter_s = shutter ? *shutter : *shutter_alias;
    if (auto v = f.number("iso", 1, 1e7)) e.iso = *v;
    if (auto v = f.number("percentile", 0, 100)) e.percentile = *v;
    if (auto v = f.number("percentile_target", 1e-6, 1e4)) e.percentile_target = *v;
    if (auto v = f.number("ignore_dark_fraction", 0, 0.99)) e.ignore_dark_fraction = *v;
    if (auto v = f.number("ignore_bright_fraction", 0, 0.99)) e.ignore_bright_fraction = *v;
    if (e.ignore_dark_fraction + e.ignore_bright_fraction >= 1.0)
      fail("request.value", "exposure: ignore_dark_fraction + ignore_bright_fraction must be below 1",
           "exposure.ignore_bright_fraction");
    e.illuminance_lux = f.number("illuminance_lux", 1e-6, 1e7);
    if (auto v = f.number("adaptation_time_s", 0, 1000)) e.adaptation_time_s = *v;
    f.finish();
  }
  if (top_comp) e.compensation_ev = *top_comp;
}

void parse_grade(Fields& top, Request& r, const ParseContext& ctx) {
  const json* g = top.get("grade");
  if (!g) return;
  Fields f(*g, "grade");
  GradeSpec spec;
  const auto lut = f.string("lut", 4096);
  if (!lut) fail("request.value", "grade.lut: required (a LUT file in the asset root)", "grade.lut");
  spec.lut = resolve(ctx, *lut, "grade.lut");
  const auto shaper = f.string("shaper", 32);
  check_choice(shaper, "grade.shaper", grade::parse_shaper, "pq, log2, sqrt, sqrt-sqrt, none");
  spec.shaper = shaper.value_or("");
  const auto placement = f.string("placement", 32);
  check_choice(placement, "grade.placement", grade::parse_placement, "scene, display, baked");
  spec.placement = placement.value_or("display");
  spec.trilinear = f.boolean("trilinear").value_or(false);
  f.finish();
  r.grade = std::move(spec);
}

void parse_ui(Fields& top, Request& r, const ParseContext& ctx) {
  const json* u = top.get("ui");
  if (!u) return;
  Fields f(*u, "ui");
  UiSpec ui;
  const auto path = f.string("path", 4096);
  const auto b64 = f.string("png_base64", ctx.limits.max_ui_bytes / 3 * 4 + 8);
  if (path && b64) fail("request.conflict", "ui: give path or png_base64, not both", "ui.path");
  if (b64 && b64->empty()) fail("request.value", "ui.png_base64: empty (a base64 PNG is required)", "ui.png_base64");
  if (!path && !b64) fail("request.value", "ui: needs path (a PNG in the asset root) or png_base64", "ui.path");
  if (path) ui.path = resolve(ctx, *path, "ui.path");
  if (b64) {
    auto bytes = decode_base64(*b64, ctx.limits.max_ui_bytes);
    if (!bytes) fail(bytes.error().code, "ui.png_base64: " + bytes.error().message, "ui.png_base64");
    ui.png = std::move(*bytes);
  }
  ui.x = int(f.integer("x", -kMaxImageDimension, kMaxImageDimension).value_or(0));
  ui.y = int(f.integer("y", -kMaxImageDimension, kMaxImageDimension).value_or(0));
  ui.scale = f.number("scale", 1e-3, 64).value_or(1.0);
  ui.dim = f.number("dim", 0, 1).value_or(0.0);
  ui.srgb_blend = f.boolean("srgb_blend").value_or(false);
  ui.premultiplied = f.boolean("premultiplied").value_or(false);
  f.finish();
  r.ui = std::move(ui);
}

void parse_output(Fields& top, Request& r) {
  r.dump = top.boolean("dump").value_or(false);
  if (const auto name = top.string("name", 256)) {
    if (auto v = validate_dump_name(*name); !v) throw Fail{v.error()};
    r.name = *name;
  }
  if (const json* fm = top.get("formats")) {
    if (!fm->is_array()) fail("request.type", "formats: expected an array of strings", "formats");
    if (fm->size() > 8) fail("request.limit", "formats: at most 8 entries", "formats");
    for (const auto& e : *fm) {
      if (!e.is_string()) fail("request.type", "formats: expected an array of strings", "formats");
      const auto& s = e.get_ref<const std::string&>();
      if (s != "png" && s != "exr" && s != "raw")
        fail("request.value", fmt::format("formats: unknown format '{}' (one of: png, exr, raw)", s.substr(0, 32)),
             "formats");
      if (std::find(r.formats.begin(), r.formats.end(), s) == r.formats.end()) r.formats.push_back(s);
    }
    if (!r.formats.empty() && !r.dump) fail("request.conflict", "formats: only meaningful with \"dump\": true", "formats");
    if (r.display.target.mode == Mode::scrgb && std::find(r.formats.begin(), r.formats.end(), "png") != r.formats.end())
      fail("request.value", "formats: scrgb has no PNG form (use exr or raw)", "formats");
  }
}

// ---- POST /v1/pattern --------------------------------------------------------------------

// Reads one parameter under "params" with its catalogue type and range.
void parse_pattern_param(Fields& pf, const PatternParam& p, PatternSpec& spec) {
  if (p.type == PatternParam::Type::boolean) {
    spec.labels = *pf.boolean(p.name);
    return;
  }
  const bool integer = p.type == PatternParam::Type::integer;
  const double v = integer ? double(*pf.integer(p.name, std::int64_t(p.min), std::int64_t(p.max)))
                           : *pf.number(p.name, p.min, p.max);
  if (p.name == "level_nits") spec.level_nits = v;
  else if (p.name == "area_percent") spec.area_percent = v;
  else if (p.name == "steps") spec.steps = int(v);
}

void parse_pattern_params(Fields& top, const PatternEntry& entry, PatternSpec& spec) {
  const json* p = top.get("params");
  if (!p) return;
  Fields pf(*p, "params");
  for (auto it = p->begin(); it != p->end(); ++it) {
    const PatternParam* param = find_param(entry, it.key());
    if (!param) {
      const std::string f = pf.field(it.key().substr(0, 64));
      fail("request.unknown_field", fmt::format("{}: not a parameter of pattern {} (its parameters: {})", f,
                                                entry.name, param_names(entry)), f);
    }
    parse_pattern_param(pf, *param, spec);
  }
  pf.finish();
}

// Patterns are 1920x1080 layouts by default (the BT.2111 one is defined at that size),
// smaller when the configured limits are.
void parse_pattern_size(Fields& top, Request& r, const ParseContext& ctx) {
  const auto& lim = ctx.limits;
  r.width = int(top.integer("width", 1, lim.max_width, "request.limit").value_or(std::min(1920, lim.max_width)));
  r.height = int(top.integer("height", 1, lim.max_height, "request.limit").value_or(std::min(1080, lim.max_height)));
  if (std::int64_t(r.width) * r.height > lim.max_pixels)
    fail("request.limit", fmt::format("width x height: {} pixels, at most {}", std::int64_t(r.width) * r.height,
                                      lim.max_pixels),
         "width");
}

void parse_pattern(Fields& top, Request& r, const ParseContext& ctx) {
  const auto name = top.string("pattern", 64);
  if (!name) fail("request.value", fmt::format("pattern: required (one of: {})", pattern_names()), "pattern");
  const PatternEntry* entry = find_pattern_entry(*name);
  if (!entry)
    fail("request.value", fmt::format("pattern: unknown pattern '{}' (one of: {})", *name, pattern_names()), "pattern");
  r.pattern.name = *name;
  parse_pattern_params(top, *entry, r.pattern);
  parse_pattern_size(top, r, ctx);
}

// A pattern's mode restriction, checked once the display is known (not for "auto" or an
// EDID, whose mode is only known when the display is read: the handler checks those).
void check_pattern_mode(const Request& r) {
  const PatternEntry* entry = find_pattern_entry(r.pattern.name);
  if (entry->modes.empty() || r.display.auto_detect || !r.display.edid_path.empty()) return;
  const Mode mode = r.display.target.mode;
  if (std::find(entry->modes.begin(), entry->modes.end(), mode) != entry->modes.end()) return;
  std::string modes;
  for (Mode m : entry->modes) modes += (modes.empty() ? "" : ", ") + std::string(to_string(m));
  fail("request.value", fmt::format("display.mode: pattern {} exists for {} only, not {}", entry->name, modes,
                                    to_string(mode)),
       "display.mode");
}

// Patterns are display light encoded with the clip curve: scene-referred options would
// be ignored, so they are refused by name rather than as anonymous unknown fields.
void refuse_scene_options(const Fields& top) {
  for (const char* k : {"tone", "exposure", "exposure_comp_ev", "gamut", "grade", "ui", "dither"})
    if (top.has(k))
      fail("request.unknown_field", fmt::format("{}: does not apply to patterns (they are display light, encoded "
                                                "with the clip curve)", k), k);
}

// ---- the request as a whole ----------------------------------------------------------------

void parse_scene_referred(Fields& top, Request& r, const ParseContext& ctx) {
  parse_tone(top, r);
  parse_exposure(top, r);
  if (const auto g = top.string("gamut", 16)) {
    if (*g != "ictcp" && *g != "clip") fail("request.value", "gamut: one of ictcp, clip", "gamut");
    r.gamut = *g;
  }
  parse_grade(top, r, ctx);
  parse_ui(top, r, ctx);
  r.dither = top.boolean("dither").value_or(false);
}

void parse_input_units(Fields& top, Request& r) {
  if (const auto in = top.string("input", 16)) {
    if (*in != "relative" && *in != "absolute") fail("request.value", "input: one of relative, absolute", "input");
    r.input = *in;
  }
}

Request parse_fields(const json& body, const ParseContext& ctx) {
  Request r;
  r.endpoint = ctx.endpoint;
  Fields top(body, "");
  switch (ctx.endpoint) {
    case Endpoint::render:
      parse_scene(top, r, ctx);
      parse_camera(top, r);
      parse_size(top, r, ctx);
      break;
    case Endpoint::encode: parse_input_units(top, r); break;
    case Endpoint::pattern:
      parse_pattern(top, r, ctx);
      refuse_scene_options(top);
      break;
  }
  parse_display(top, r, ctx);
  if (ctx.endpoint == Endpoint::pattern) check_pattern_mode(r);
  else parse_scene_referred(top, r, ctx);
  parse_output(top, r);
  r.timeout_s = top.number("timeout_s", 0.001, ctx.limits.max_request_seconds);
  top.finish();
  return r;
}

// ---- POST /v1/selftest ---------------------------------------------------------------------

constexpr std::string_view kSelftestModes[] = {"sdr-srgb", "sdr", "sdr-bt1886", "hdr10", "scrgb", "hlg"};

SelftestRequest parse_selftest_fields(const json& body, const ParseContext& ctx) {
  SelftestRequest r;
  Fields top(body, "");
  if (const auto mode = top.string("mode", 32)) {
    if (std::find(std::begin(kSelftestModes), std::end(kSelftestModes), *mode) == std::end(kSelftestModes))
      fail("request.value",
           fmt::format("mode: unknown mode '{}' (one of: sdr-srgb, sdr, sdr-bt1886, hdr10, scrgb, hlg)", *mode), "mode");
    r.mode = *mode;
  }
  r.peak_nits = top.number("peak_nits", 1e-3, 10000);
  r.render = top.boolean("render").value_or(true);
  r.timeout_s = top.number("timeout_s", 0.001, ctx.limits.max_request_seconds);
  top.finish();
  return r;
}

json vec_json(const std::optional<std::array<double, 3>>& v) {
  return v ? json::array({(*v)[0], (*v)[1], (*v)[2]}) : json(nullptr);
}

std::uint64_t fnv1a(const std::uint8_t* p, std::size_t n) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

}  // namespace

Result<Request> parse_request_json(const nlohmann::json& body, const ParseContext& ctx) {
  try {
    return parse_fields(body, ctx);
  } catch (const Fail& f) {
    return f.error;
  } catch (const nlohmann::json::exception& e) {
    return make_error("request.type", std::string("request: ") + e.what(), "");
  }
}

int json_nesting_depth(std::string_view body) {
  int depth = 0, max_depth = 0;
  bool in_string = false, escaped = false;
  for (char c : body) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      max_depth = std::max(max_depth, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return max_depth;
}

namespace {

// The body as a JSON object: size, nesting depth, NUL bytes and syntax checked by the one
// bounded parse every entry point uses (input_bounds.hpp).
Result<json> parse_json_object(std::string_view body, const ParseContext& ctx) {
  return parse_json_object_bounded(body, ctx.limits);
}

}  // namespace

Result<Request> parse_request(std::string_view body, const ParseContext& ctx) {
  auto doc = parse_json_object(body, ctx);
  if (!doc) return doc.error();
  return parse_request_json(*doc, ctx);
}

Result<SelftestRequest> parse_selftest_request(std::string_view body, const ParseContext& ctx) {
  // No body at all means every default, as `hdrd selftest` without options.
  if (body.find_first_not_of(" \t\r\n") == std::string_view::npos) return SelftestRequest{};
  auto doc = parse_json_object(body, ctx);
  if (!doc) return doc.error();
  try {
    return parse_selftest_fields(*doc, ctx);
  } catch (const Fail& f) {
    return f.error;
  } catch (const nlohmann::json::exception& e) {
    return make_error("request.type", std::string("request: ") + e.what(), "");
  }
}

nlohmann::json SelftestRequest::canonical() const {
  return {{"endpoint", "selftest"}, {"mode", mode}, {"peak_nits", peak_nits ? json(*peak_nits) : json(nullptr)},
          {"render", render}};
}

nlohmann::json Request::canonical() const {
  json j;
  static constexpr const char* kEndpoints[] = {"render", "encode", "pattern"};
  j["endpoint"] = kEndpoints[int(endpoint)];
  if (endpoint == Endpoint::pattern) {
    j["pattern"] = {{"name", pattern.name}, {"level_nits", pattern.level_nits}, {"area_percent", pattern.area_percent},
                    {"steps", pattern.steps}, {"labels", pattern.labels}};
    j["width"] = width;
    j["height"] = height;
  } else if (endpoint == Endpoint::render) {
    static constexpr const char* kKinds[] = {"builtin", "inline", "scene_file", "gltf"};
    j["scene"] = {{"kind", kKinds[int(scene.kind)]}, {"name", scene.name}, {"inline", scene.inline_scene},
                  {"path", scene.path.string()}};
    j["camera"] = {{"position", vec_json(camera.position)}, {"target", vec_json(camera.target)},
                   {"fov_y_deg", camera.fov_y_deg ? json(*camera.fov_y_deg) : json(nullptr)}};
    j["width"] = width;
    j["height"] = height;
    j["samples"] = samples;
  } else {
    j["input"] = input;
  }
  const auto& t = display.target;
  j["display"] = {{"auto", display.auto_detect}, {"edid", display.edid_path.string()},
                  {"mode", to_string(t.mode)}, {"peak_nits", t.peak_nits}, {"black_nits", t.black_nits},
                  {"paper_white_nits", t.paper_white_nits}, {"ui_white_nits", t.ui_white_nits},
                  {"sdr_white_nits", t.sdr_white_nits}, {"range", to_string(t.range)},
                  {"sdr_curve", to_string(t.sdr_curve)}, {"bits", t.bits}, {"given", display.given}};
  j["tone"] = {{"curve", tone.curve}, {"params", tone.params}, {"apply", tone.apply}};
  const auto& e = exposure;
  j["exposure"] = {{"mode", exposure::to_string(e.mode)}, {"compensation_ev", e.compensation_ev},
                   {"gain", e.gain}, {"ev100", e.ev100 ? json(*e.ev100) : json(nullptr)},
                   {"aperture_f", e.aperture_f}, {"shutter_s", e.shutter_s}, {"iso", e.iso},
                   {"percentile", e.percentile}, {"percentile_target", e.percentile_target},
                   {"ignore_dark_fraction", e.ignore_dark_fraction},
                   {"ignore_bright_fraction", e.ignore_bright_fraction},
                   {"illuminance_lux", e.illuminance_lux ? json(*e.illuminance_lux) : json(nullptr)},
                   {"adaptation_time_s", e.adaptation_time_s}};
  j["exposure"]["mode_given"] = exposure_mode_given;
  j["gamut"] = gamut;
  j["grade"] = grade ? json{{"lut", grade->lut.string()}, {"shaper", grade->shaper},
                            {"placement", grade->placement}, {"trilinear", grade->trilinear}}
                     : json(nullptr);
  if (ui) {
    j["ui"] = {{"path", ui->path.string()},
               {"png_fnv1a", ui->png.empty() ? json(nullptr) : json(fnv1a(ui->png.data(), ui->png.size()))},
               {"png_bytes", ui->png.size()}, {"x", ui->x}, {"y", ui->y}, {"scale", ui->scale},
               {"dim", ui->dim}, {"srgb_blend", ui->srgb_blend}, {"premultiplied", ui->premultiplied}};
  } else {
    j["ui"] = nullptr;
  }
  j["dump"] = dump;
  j["formats"] = formats;
  j["name"] = name;
  j["dither"] = dither;
  return j;
}

// ---- query parameters (POST /v1/encode?mode=hdr10&peak_nits=1000) ---------------------

std::span<const QueryParam> query_params() {
  using T = QueryParam::Type;
  static constexpr QueryParam kParams[] = {
      {"mode", "/display/mode", T::string},
      {"peak_nits", "/display/peak_nits", T::number},
      {"black_nits", "/display/black_nits", T::number},
      {"paper_white_nits", "/display/paper_white_nits", T::number},
      {"ui_white_nits", "/display/ui_white_nits", T::number},
      {"sdr_white_nits", "/display/sdr_white_nits", T::number},
      {"range", "/display/range", T::string},
      {"bits", "/display/bits", T::integer},
      {"sdr_curve", "/display/sdr_curve", T::string},
      {"curve", "/tone/curve", T::string},
      {"apply", "/tone/apply", T::string},
      {"exposure", "/exposure/mode", T::string},
      {"exposure_comp_ev", "/exposure_comp_ev", T::number},
      {"ev100", "/exposure/ev100", T::number},
      {"input", "/input", T::string},
      {"gamut", "/gamut", T::string},
      {"dump", "/dump", T::boolean},
      {"name", "/name", T::string},
      {"dither", "/dither", T::boolean},
  };
  return kParams;
}

Result<nlohmann::json> query_to_request_json(const std::vector<std::pair<std::string, std::string>>& query) {
  json j = json::object();
  for (const auto& [key, value] : query) {
    const std::string field = key.substr(0, 64), shown = one_line(field);
    if (key == "display" && value == "auto") {
      j["display"] = "auto";
      continue;
    }
    const QueryParam* param = nullptr;
    for (const auto& p : query_params())
      if (p.name == key) param = &p;
    if (!param) return make_error("request.unknown_field", fmt::format("query parameter '{}': unknown", shown), field);
    const json::json_pointer ptr{std::string(param->json_path)};
    if (j.contains(ptr))
      return make_error("request.conflict", fmt::format("query parameter '{}': given twice", shown), field);
    switch (param->type) {
      case QueryParam::Type::string:
        j[ptr] = value;
        break;
      case QueryParam::Type::boolean:
        if (value == "true" || value == "1" || value.empty()) j[ptr] = true;
        else if (value == "false" || value == "0") j[ptr] = false;
        else return make_error("request.type", fmt::format("query parameter '{}': expected true or false", shown), field);
        break;
      case QueryParam::Type::number:
      case QueryParam::Type::integer: {
        // JSON's number grammar is the strictest readily available check.
        json n = json::parse(value, nullptr, false);
        if (n.is_discarded() || !n.is_number())
          return make_error("request.type", fmt::format("query parameter '{}': expected a number", shown), field);
        j[ptr] = n;
        break;
      }
    }
  }
  return j;
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

}  // namespace hdrd::daemon

#include "job/build.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "display/displays.hpp"
#include "display/profile.hpp"
#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/io/io.hpp"
#include "job/pattern_params.hpp"

namespace hdrd::job {

Result<DisplayTarget> resolve_display(const FrameRequest& r, std::vector<std::string>* warnings,
                                      const io::InputFiles& files) {
  const std::string connector = r.text("display.connector"), edid = r.text("display.edid"),
                    profile_file = r.text("display.profile");
  std::optional<display::Profile> profile;
  if (!connector.empty() || !edid.empty() || !profile_file.empty()) {
    auto p = display::select_profile(connector, edid, profile_file, files);
    if (!p) {
      Error e = p.error();
      if (e.field.empty() || e.field == "path") e.field = !edid.empty() ? "display.edid" : !profile_file.empty() ? "display.profile" : "display.connector";
      return e;
    }
    profile = *p;
    if (!profile && !connector.empty() && warnings)
      warnings->push_back(fmt::format("display {}: no display attached (headless); using the mode's defaults", connector));
  }
  const auto asked = parse_mode(r.text("display.mode"));
  Mode mode = asked ? *asked : profile ? profile->mode : Mode::hdr10;
  // SDR video is BT.709 (H.273 transfer 1, the BT.1886 display EOTF it implies), which
  // players and TVs expect of video, not the sRGB curve of stills (transfer 13): the frames
  // are encoded as sdr-bt1886 unless video.sdr_transfer or an explicit SDR curve says otherwise.
  if (mode == Mode::sdr && r.has("video.codec") && r.text("video.sdr_transfer") != "srgb" &&
      !r.has("display.sdr_curve")) {
    mode = Mode::sdr_bt1886;
    if (warnings)
      warnings->push_back("SDR video is BT.709 (H.273 transfer 1, displayed with BT.1886): the frames are encoded as "
                          "sdr-bt1886 (--sdr-video-transfer srgb keeps the sRGB curve, transfer 13)");
  }
  if (profile && warnings) {
    warnings->push_back("display profile: " + profile->source + " (" + profile->mode_reason + ")");
    for (const auto& n : profile->notes) warnings->push_back(n);
    // A mode asked for whose transfer the display does not signal: it may show it wrongly.
    const bool unsignalled = (mode == Mode::hdr10 && !profile->signals_pq) || (mode == Mode::hlg && !profile->signals_hlg);
    if (asked && unsignalled)
      warnings->push_back(fmt::format("display {} does not signal {} (it signals {}): {} was asked for and is sent "
                                      "anyway; the display may not decode it",
                                      profile->source, mode == Mode::hdr10 ? "SMPTE ST 2084 (PQ)" : "HLG",
                                      profile->signals_pq && profile->signals_hlg ? "PQ and HLG"
                                      : profile->signals_pq                       ? "PQ only"
                                      : profile->signals_hlg                      ? "HLG only"
                                                                                  : "no HDR transfer",
                                      to_string(mode)));
  }
  auto t = resolve_target(mode, profile ? display::profile_levels(*profile) : LevelSettings{}, request_levels(r),
                          profile ? profile->source : "");
  if (!t) {
    Error e = t.error();
    e.code = profile ? "display.invalid" : "request.value";
    return e;
  }
  const bool paper_white_asked =
      r.has("display.paper_white_nits") || (profile && display::profile_levels(*profile).paper_white_nits);
  if (auto note = paper_white_note(*t, paper_white_asked); note && warnings && !mode_info(mode).sdr())
    warnings->push_back(*note);
  if (mode_info(mode).sdr() && r.has("display.paper_white_nits") && t->paper_white_nits != t->peak_nits && warnings)
    warnings->push_back(fmt::format("SDR paper white {} cd/m2 differs from the peak {} cd/m2", t->paper_white_nits,
                                    t->peak_nits));
  return t;
}

Result<void> check_pattern_mode(const FrameRequest& r, const DisplayTarget& target) {
  const PatternEntry* entry = find_pattern_entry(r.text("pattern"));
  if (!entry || entry->modes.empty()) return {};
  if (std::find(entry->modes.begin(), entry->modes.end(), target.mode) != entry->modes.end()) return {};
  std::string modes;
  for (Mode m : entry->modes) modes += (modes.empty() ? "" : ", ") + std::string(to_string(m));
  return make_error("request.value",
                    fmt::format("display.mode: pattern {} exists for {} only, not {}", entry->name, modes,
                                to_string(target.mode)),
                    "display.mode");
}

namespace {

Result<std::shared_ptr<const grade::Grade>> load_grade(const FrameRequest& r, const DisplayTarget& target,
                                                       std::vector<std::string>* warnings, const io::InputFiles& files) {
  if (r.is_null("grade.lut") && r.is_null("grade.ocio_look") && r.is_null("grade.ocio_display"))
    return std::shared_ptr<const grade::Grade>();
  grade::GradeSettings gs;
  gs.lut_path = r.text("grade.lut");
  gs.trilinear = r.boolean("grade.trilinear");
  gs.ocio_config = r.text("grade.ocio_config");
  gs.ocio_look = r.text("grade.ocio_look");
  gs.ocio_display = r.text("grade.ocio_display");
  gs.ocio_view = r.text("grade.ocio_view");
  gs.files = files;
  if (const std::string shaper = r.text("grade.shaper"); !shaper.empty()) {
    // "log2", or with its range: "log2:-8:8", "sqrt:16" (checked when parsed).
    const auto spec = lut::parse_shaper_spec(shaper);
    if (!spec) return spec.error();
    gs.shaper = spec->kind;
    if (shaper.find(':') != std::string::npos) gs.shaper_range = std::pair{spec->min, spec->max};
  }
  gs.placement = *grade::parse_placement(r.text("grade.placement"));
  auto g = grade::load_grade(gs, target.peak_nits, warnings);
  if (!g) {
    Error e = g.error();
    if (e.field.empty()) e.field = gs.lut_path.empty() ? "grade.ocio_config" : "grade.lut";
    return e;
  }
  return *g;
}

Result<UiSettings> load_ui(const FrameRequest& r, const io::InputFiles& files) {
  UiSettings ui;
  if (r.is_null("ui.path") && r.ui_png.empty()) return ui;
  const bool premultiplied = r.boolean("ui.premultiplied");
  auto overlay = r.ui_png.empty() ? io::read_overlay_png(r.text("ui.path"), premultiplied, {}, files)
                                  : io::read_overlay_png_memory(r.ui_png, premultiplied);
  if (!overlay) {
    Error e = overlay.error();
    e.field = r.ui_png.empty() ? "ui.path" : "ui.png_base64";
    return e;
  }
  ui.overlay = std::make_shared<const OverlayImage>(std::move(*overlay));
  ui.x = static_cast<int>(r.integer("ui.x"));
  ui.y = static_cast<int>(r.integer("ui.y"));
  ui.scale = r.number("ui.scale");
  ui.dim = r.number("ui.dim");
  ui.srgb_blend = r.text("ui.blend") == "srgb";
  return ui;
}

}  // namespace

exposure::Mode exposure_mode(const FrameRequest& r) {
  const std::string m = r.text("exposure.mode");
  if (m != "auto") return *exposure::parse_mode(m);
  if (!r.is_null("exposure.ev100")) return exposure::Mode::camera;
  // Light-based exposure only when asked for by its illuminance: a render's own dominant
  // light is the sun for an interior seen through a door (the hdr scene), which left the
  // room black; renders meter their picture as Unreal does (histogram window average).
  if (!r.is_null("exposure.illuminance_lux")) return exposure::Mode::light;
  return r.source == Source::render ? exposure::Mode::histogram : exposure::Mode::manual;
}

Result<EncodeSettings> encode_settings(const FrameRequest& r, const DisplayTarget& target, int threads,
                                       std::vector<std::string>* warnings, LoadedResources* resources,
                                       const io::InputFiles& files) {
  EncodeSettings s;
  s.target = target;
  s.threads = threads;
  s.dither = r.boolean("dither");
  s.gamut = *parse_gamut_mapping(r.text("gamut"));
  s.gamut_to_display = r.text("gamut_target") == "display";
  s.tone.curve = r.text("tone.curve");
  for (const auto& [k, v] : r.at("tone.params").items()) s.tone.params[k] = v.get<double>();
  if (const std::string apply = r.text("tone.apply"); !apply.empty()) s.tone.apply = tonemap::parse_apply(apply);
  s.tone.max_frame_average_nits = r.optional_number("tone.max_frame_average_nits");

  auto& ex = s.exposure;
  ex.mode = exposure_mode(r);
  ex.compensation_ev = r.number("exposure.compensation_ev");
  ex.gain = r.number("exposure.gain");
  if (!r.is_null("exposure.ev100")) ex.ev100 = r.number("exposure.ev100");
  ex.aperture_f = r.number("exposure.aperture_f");
  ex.shutter_s = r.number("exposure.shutter_s");
  ex.iso = r.number("exposure.iso");
  ex.percentile = r.optional_number("exposure.percentile");
  ex.min_ev100 = r.number("exposure.min_ev100");
  ex.max_ev100 = r.number("exposure.max_ev100");
  ex.percentile_target = r.number("exposure.percentile_target");
  ex.ignore_dark_fraction = r.number("exposure.ignore_dark_fraction");
  ex.ignore_bright_fraction = r.number("exposure.ignore_bright_fraction");
  if (!r.is_null("exposure.illuminance_lux")) ex.illuminance_lux = r.number("exposure.illuminance_lux");

  if (resources && resources->loaded) {
    s.ui = resources->ui;
    s.grade = resources->grade;
    if (warnings) warnings->insert(warnings->end(), resources->warnings.begin(), resources->warnings.end());
    return s;
  }
  auto ui = load_ui(r, files);
  if (!ui) return ui.error();
  s.ui = std::move(*ui);
  std::vector<std::string> grade_warnings;
  auto g = load_grade(r, target, &grade_warnings, files);
  if (!g) return g.error();
  s.grade = std::move(*g);
  if (warnings) warnings->insert(warnings->end(), grade_warnings.begin(), grade_warnings.end());
  if (resources) *resources = {true, s.ui, s.grade, std::move(grade_warnings)};
  return s;
}

shading::RenderRequest render_request(const FrameRequest& r, const JobOptions& options) {
  shading::RenderRequest rq;
  switch (r.scene.kind) {
    case SceneRef::Kind::builtin: rq.scene = r.scene.name; break;
    case SceneRef::Kind::file: rq.scene = r.scene.path.string(); break;
    case SceneRef::Kind::inline_json: rq.scene_json = r.scene.inline_scene; break;
  }
  rq.width = static_cast<int>(r.integer("width"));
  rq.height = static_cast<int>(r.integer("height"));
  rq.samples = std::min(static_cast<int>(r.integer("samples")), shading::kMaxSamples);
  const auto vec = [](const nlohmann::json& v) { return shading::Vec3{v[0].get<double>(), v[1].get<double>(), v[2].get<double>()}; };
  if (!r.is_null("camera.position") || !r.is_null("camera.target") || !r.is_null("camera.fov_y_deg")) {
    shading::CameraOverride cam;
    if (!r.is_null("camera.position")) cam.position = vec(r.at("camera.position"));
    if (!r.is_null("camera.target")) cam.target = vec(r.at("camera.target"));
    cam.yfov_deg = r.optional_number("camera.fov_y_deg");
    rq.camera = cam;
  }
  // The world's light: a map file or the sky (any sky field given), else the scene's own.
  const bool sky = !r.is_null("environment.sky.sun_elevation_deg") || !r.is_null("environment.sky.sun_azimuth_deg") ||
                   !r.is_null("environment.sky.turbidity") || !r.is_null("environment.sky.ground_albedo") ||
                   r.has("environment.sky.sun");
  const bool sky_sun = r.boolean("environment.sky.sun");
  const std::string env_file = r.text("environment.file");
  const double env_scale = r.number("environment.scale"), env_rotation = r.number("environment.rotation_deg");
  if (sky || !env_file.empty()) {
    shading::EnvironmentSpec env;
    env.file = env_file;
    env.files = options.files;
    if (sky) {
      shading::SkyParams p;
      p.sun_elevation_deg = r.optional_number("environment.sky.sun_elevation_deg").value_or(p.sun_elevation_deg);
      p.sun_azimuth_deg = r.optional_number("environment.sky.sun_azimuth_deg").value_or(p.sun_azimuth_deg);
      p.turbidity = r.optional_number("environment.sky.turbidity").value_or(p.turbidity);
      p.ground_albedo = r.optional_number("environment.sky.ground_albedo").value_or(p.ground_albedo);
      p.sun = sky_sun;
      env.sky = p;
    }
    env.scale = env_scale;
    env.rotation_deg = env_rotation;
    rq.environment = env;
  }
  rq.energy_compensation = r.boolean("energy_compensation");
  rq.load.gltf_emissive_nits = r.number("gltf_emissive_nits");
  rq.time_s = options.time_s.value_or(r.number("start_s"));
  rq.previous_time_s = options.previous_time_s;
  rq.load.base_dir = options.scene_base_dir;
  rq.load.allow_files = options.scene_files;
  rq.load.files = options.files;
  rq.load.limits.max_lights = options.max_lights;
  return rq;
}

patterns::PatternOptions pattern_options(const FrameRequest& r) {
  patterns::PatternOptions o;
  o.width = static_cast<int>(r.integer("width"));
  o.height = static_cast<int>(r.integer("height"));
  o.level_nits = r.optional_number("params.level_nits").value_or(0);
  o.area_percent = r.number("params.area_percent");
  o.steps = r.is_null("params.steps") ? 0 : static_cast<int>(r.integer("params.steps"));
  o.labels = r.boolean("params.labels");
  return o;
}

Error pattern_error(Error e) {
  if (e.field == "mode") e.field = "display.mode";
  else if (e.field == "level") e.field = "params.level_nits";
  else if (e.field == "area") e.field = "params.area_percent";
  else if (e.field == "steps") e.field = "params.steps";
  return e;
}

}  // namespace hdrd::job

#include "tools/hdrd/pipeline_options.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <span>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/displays.hpp"
#include "display/profile.hpp"
#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/result.hpp"
#include "patterns/plot.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {

namespace {

[[noreturn]] void fail(const std::string& option, const std::string& message) {
  throw HdrdError(make_error("cli.option", option + ": " + message, option));
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

void add_pipeline_options(CLI::App& app, PipelineOptions& o) {
  const std::string d = "Display";
  app.add_option("--mode", o.mode, "Output mode: hdr10, hlg, scrgb, sdr, sdr-bt1886 (default: the display's, else hdr10)")->group(d);
  app.add_option("--peak", o.peak_nits, "Display peak luminance, cd/m2 (mode default: hdr10/hlg/scrgb 1000, sdr 100)")->group(d);
  app.add_option("--black", o.black_nits, "Display black luminance, cd/m2 (hdr10 0.005, sdr 0.1, hlg/scrgb 0)")->group(d);
  app.add_option("--paper-white", o.paper_white_nits, "Luminance of relative 1.0 (diffuse white), cd/m2 (HDR 203, SDR = peak)")->group(d);
  app.add_option("--ui-white", o.ui_white_nits, "Luminance of UI white, cd/m2 (default: paper white)")->group(d);
  app.add_option("--sdr-white", o.sdr_white_nits, "Where SDR content's white lands in an HDR frame, cd/m2 (default: paper white)")->group(d);
  app.add_option("--range", o.range, "Code range: full or narrow (KMS scan-out is always full)")->group(d)->capture_default_str();
  app.add_option("--bits", o.bits, "Bits per channel: 10 (hdr10, hlg), 8 or 10 (sdr)")->group(d);
  app.add_option("--sdr-curve", o.sdr_curve, "SDR transfer: srgb (piecewise) or gamma22")->group(d)->capture_default_str();
  app.add_option("--display", o.display, "'auto' (first connected HDR-capable display) or a connector name: its mode, levels, primaries")->group(d);
  app.add_option("--edid", o.edid_path, "Take the display's mode, levels and primaries from an EDID file (useful headless)")->group(d);
  app.add_option("--profile", o.profile_override, "Display profile override file (TOML or JSON; see docs/displays.md)")->group(d);

  const std::string t = "Tone mapping";
  app.add_option("--tonemap", o.tonemap, "Tone curve (see 'hdrd tonemap --list'; default pq-shoulder)")->group(t);
  app.add_option("--tonemap-param", o.tonemap_params, "Curve parameter NAME=VALUE (repeatable)")->group(t);
  app.add_option("--tonemap-apply", o.tonemap_apply, "per-channel, max-rgb or luminance (default: the curve's)")->group(t);
  app.add_option("--gamut", o.gamut, "Gamut mapping after tone mapping: ictcp (constant hue) or clip")->group(t)->capture_default_str();

  const std::string e = "Exposure";
  app.add_option("--exposure-mode", o.exposure_mode, "manual, camera, log-average, histogram or light")->group(e);
  app.add_option("--exposure", o.exposure_ev, "Compensation in stops, applied last in every mode (+ brightens)")->group(e);
  app.add_option("--ev100", o.ev100, "Camera exposure value at ISO 100 (implies --exposure-mode camera)")->group(e);
  app.add_option("--aperture", o.aperture, "Camera f-number (camera mode)")->group(e);
  app.add_option("--shutter", o.shutter, "Camera shutter time, seconds (camera mode)")->group(e);
  app.add_option("--iso", o.iso, "Camera ISO (camera mode)")->group(e);
  app.add_option("--gain", o.gain, "Manual mode: extra linear gain")->group(e);
  app.add_option("--illuminance", o.illuminance, "Light mode: dominant illuminance, lux")->group(e);
  app.add_option("--percentile", o.percentile, "Histogram mode: percentile metered (default 50, the median)")->group(e);
  app.add_option("--percentile-target", o.percentile_target, "Histogram mode: value the percentile maps to (default 0.18)")->group(e);
  app.add_option("--ignore-dark", o.ignore_dark, "Histogram mode: fraction of darkest pixels ignored (default 0)")->group(e);
  app.add_option("--ignore-bright", o.ignore_bright, "Histogram mode: fraction of brightest pixels ignored (default 0.02)")->group(e);

  const std::string u = "UI overlay";
  app.add_option("--ui", o.ui_path, "sRGB RGBA PNG composited at UI white")->group(u);
  app.add_flag("--ui-premultiplied", o.ui_premultiplied, "The overlay's alpha is premultiplied")->group(u);
  app.add_option("--ui-pos", o.ui_pos, "Overlay top-left X Y in output pixels")->expected(2)->delimiter(',')->group(u);
  app.add_option("--ui-scale", o.ui_scale, "Overlay scale (bilinear)")->group(u);
  app.add_option("--ui-blend", o.ui_blend, "linear (default) or srgb (for UIs authored with sRGB blending)")->group(u);
  app.add_option("--ui-dim", o.ui_dim, "Dim the frame under translucent UI by this fraction of alpha")->group(u);

  const std::string g = "Grading";
  app.add_option("--lut", o.lut_path, "3D LUT (.cube, or any format OpenColorIO reads)")->group(g);
  app.add_option("--lut-shaper", o.lut_shaper, "Shaper for scene-referred LUTs: pq, log2, sqrt, sqrt-sqrt, optionally with its range (log2:-8:8, sqrt:16)")->group(g);
  app.add_option("--grade", o.grade_placement, "Where the LUT applies: scene, display (default) or baked")->group(g);
  app.add_option("--ocio-config", o.ocio_config, "OpenColorIO config (default: $OCIO)")->group(g);
  app.add_option("--ocio-look", o.ocio_look, "OpenColorIO look to apply")->group(g);
  app.add_option("--ocio-display", o.ocio_display, "OpenColorIO display (with --ocio-view)")->group(g);
  app.add_option("--ocio-view", o.ocio_view, "OpenColorIO view (with --ocio-display)")->group(g);
  app.add_flag("--lut-trilinear", o.lut_trilinear, "Trilinear instead of tetrahedral LUT interpolation")->group(g);

  const std::string out = "Output";
  app.add_option("--format", o.formats, "Comma-separated: png, exr, raw (default: all that apply to the mode)")->group(out);
  app.add_flag("--dither", o.dither, "Ordered dither on code values")->group(out);
  app.add_option("--threads", o.threads, "Encoder threads (0 = all cores)")->group(out);
}

EncodeSettings build_settings(const PipelineOptions& o, exposure::Mode default_exposure,
                              std::vector<std::string>* notes) {
  EncodeSettings s;
  // The display profile (--edid wins over --display), then per-mode defaults, then flags.
  auto profile = display::select_profile(o.display, o.edid_path, o.profile_override);
  if (!profile) throw HdrdError(profile.error());
  if (!o.display.empty() && !*profile && notes)
    notes->push_back("--display " + o.display + ": no display attached (headless); using the mode's defaults");
  std::optional<Mode> mode;
  if (!o.mode.empty()) {
    mode = parse_mode(o.mode);
    if (!mode) fail("--mode", fmt::format("unknown mode '{}' (hdr10, hlg, scrgb, sdr, sdr-bt1886)", o.mode));
  } else {
    mode = *profile ? (*profile)->mode : Mode::hdr10;
  }
  auto& t = s.target = default_target(*mode);
  if (*profile) {
    display::apply_profile(**profile, t, false);
    if (notes) {
      notes->push_back("display profile: " + (*profile)->source + " (" + (*profile)->mode_reason + ")");
      for (const auto& n : (*profile)->notes) notes->push_back(n);
    }
  }
  const bool sdr = *mode == Mode::sdr || *mode == Mode::sdr_bt1886;
  if (o.peak_nits) t.peak_nits = *o.peak_nits;
  if (o.black_nits) t.black_nits = *o.black_nits;
  t.paper_white_nits = o.paper_white_nits.value_or(sdr ? t.peak_nits : t.paper_white_nits);
  t.ui_white_nits = o.ui_white_nits.value_or(t.paper_white_nits);
  t.sdr_white_nits = o.sdr_white_nits.value_or(t.paper_white_nits);
  const auto range = parse_range(o.range);
  if (!range) fail("--range", fmt::format("'{}' is not full or narrow", o.range));
  t.range = *range;
  if (o.bits) t.bits = *o.bits;
  const auto curve = parse_sdr_curve(o.sdr_curve);
  if (!curve) fail("--sdr-curve", fmt::format("'{}' is not srgb or gamma22", o.sdr_curve));
  t.sdr_curve = *curve;
  t.source = "command line";
  if (auto ok = validate(t); !ok) fail("--" + ok.error().field.substr(ok.error().field.find('.') + 1), ok.error().message);

  s.tone.curve = o.tonemap;
  for (const auto& kv : o.tonemap_params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) fail("--tonemap-param", fmt::format("'{}' is not NAME=VALUE", kv));
    try {
      std::size_t used = 0;
      const double v = std::stod(kv.substr(eq + 1), &used);
      if (used != kv.size() - eq - 1) throw std::invalid_argument("trailing");
      s.tone.params[kv.substr(0, eq)] = v;
    } catch (const std::exception&) {
      fail("--tonemap-param", fmt::format("'{}' has no numeric value", kv));
    }
  }
  // Fail before any work is done: unknown curves and out-of-range parameters.
  if (!s.tone.curve.empty() || !s.tone.params.empty()) {
    const auto name = s.tone.curve.empty() ? std::string(tonemap::default_curve(t.mode)) : s.tone.curve;
    const auto* info = tonemap::find_curve(name);
    if (!info) throw HdrdError(tonemap::prepare(name, {}).error());
    if (auto r = tonemap::resolve_params(*info, s.tone.params); !r) throw HdrdError(r.error());
  }
  if (!o.tonemap_apply.empty()) {
    s.tone.apply = tonemap::parse_apply(o.tonemap_apply);
    if (!s.tone.apply) fail("--tonemap-apply", fmt::format("'{}' is not per-channel, max-rgb or luminance", o.tonemap_apply));
  }
  const auto gamut = parse_gamut_mapping(o.gamut);
  if (!gamut) fail("--gamut", fmt::format("'{}' is not ictcp or clip", o.gamut));
  s.gamut = *gamut;

  auto& ex = s.exposure;
  ex.mode = default_exposure;
  if (o.ev100 && o.exposure_mode.empty()) ex.mode = exposure::Mode::camera;
  if (!o.exposure_mode.empty()) {
    const auto m = exposure::parse_mode(o.exposure_mode);
    if (!m) fail("--exposure-mode", fmt::format("'{}' is not manual, camera, log-average, histogram or light", o.exposure_mode));
    ex.mode = *m;
  }
  ex.compensation_ev = o.exposure_ev;
  ex.ev100 = o.ev100;
  if (o.aperture) ex.aperture_f = *o.aperture;
  if (o.shutter) ex.shutter_s = *o.shutter;
  if (o.iso) ex.iso = *o.iso;
  if (o.gain) ex.gain = *o.gain;
  if (o.illuminance) ex.illuminance_lux = *o.illuminance;
  if (o.percentile) ex.percentile = *o.percentile;
  if (o.percentile_target) ex.percentile_target = *o.percentile_target;
  if (o.ignore_dark) ex.ignore_dark_fraction = *o.ignore_dark;
  if (o.ignore_bright) ex.ignore_bright_fraction = *o.ignore_bright;

  if (!o.ui_path.empty()) {
    auto overlay = io::read_overlay_png(o.ui_path, o.ui_premultiplied);
    if (!overlay) throw HdrdError(overlay.error());
    s.ui.overlay = std::make_shared<OverlayImage>(std::move(*overlay));
    if (!o.ui_pos.empty()) {
      s.ui.x = o.ui_pos[0];
      s.ui.y = o.ui_pos[1];
    }
    s.ui.scale = o.ui_scale;
    if (o.ui_blend != "linear" && o.ui_blend != "srgb") fail("--ui-blend", fmt::format("'{}' is not linear or srgb", o.ui_blend));
    s.ui.srgb_blend = o.ui_blend == "srgb";
    s.ui.dim = o.ui_dim;
  }
  if (!o.lut_path.empty() || !o.ocio_look.empty() || !o.ocio_display.empty()) {
    grade::GradeSettings gs;
    gs.lut_path = o.lut_path;
    gs.trilinear = o.lut_trilinear;
    gs.ocio_config = o.ocio_config;
    gs.ocio_look = o.ocio_look;
    gs.ocio_display = o.ocio_display;
    gs.ocio_view = o.ocio_view;
    if (!o.lut_shaper.empty()) {
      // "log2", or with its range: "log2:-8:8", "sqrt:16" (lut.hpp parse_shaper_spec).
      const auto spec = lut::parse_shaper_spec(o.lut_shaper);
      if (!spec) fail("--lut-shaper", spec.error().message);
      gs.shaper = spec->kind;
      if (o.lut_shaper.find(':') != std::string::npos) gs.shaper_range = std::pair{spec->min, spec->max};
    }
    if (!o.grade_placement.empty()) {
      const auto pl = grade::parse_placement(o.grade_placement);
      if (!pl) fail("--grade", fmt::format("'{}' is not scene, display or baked", o.grade_placement));
      gs.placement = *pl;
    }
    std::vector<std::string> warnings;
    auto g = grade::load_grade(gs, t.peak_nits, &warnings);
    if (!g) throw HdrdError(g.error());
    s.grade = *g;
    if (notes) notes->insert(notes->end(), warnings.begin(), warnings.end());
  } else if (!o.lut_shaper.empty() || !o.grade_placement.empty()) {
    fail(o.lut_shaper.empty() ? "--grade" : "--lut-shaper", "needs --lut (or an OpenColorIO look or display/view)");
  }
  s.dither = o.dither;
  s.threads = o.threads;
  if (notes && sdr && o.paper_white_nits && *o.paper_white_nits != t.peak_nits)
    notes->push_back(fmt::format("SDR paper white {} cd/m2 differs from the peak {} cd/m2", t.paper_white_nits, t.peak_nits));
  return s;
}

void add_debug_option(CLI::App& app, PipelineOptions& o) {
  app.add_option("--debug", o.debug,
                 "Extra outputs, comma-separated: heatmap (OUTBASE.heatmap.png, false colour of the display "
                 "cd/m2 decoded from the codes, with a legend)")
      ->delimiter(',')
      ->group("Output");
}

DebugOutputs parse_debug(const PipelineOptions& o) {
  DebugOutputs d;
  for (const auto& name : o.debug) {
    if (name == "heatmap") d.heatmap = true;
    else fail("--debug", fmt::format("unknown value '{}' (known: heatmap)", name));
  }
  return d;
}

std::vector<io::ExtraFile> debug_files(const EncodedFrame& frame, const DebugOutputs& debug) {
  std::vector<io::ExtraFile> out;
  if (debug.heatmap) {
    auto png = patterns::frame_heatmap(frame).png();
    if (!png) throw HdrdError(png.error());
    out.push_back({"heatmap", ".heatmap.png", std::move(*png)});
  }
  return out;
}

std::vector<io::DumpFormat> build_formats(const PipelineOptions& o, Mode mode) {
  if (o.formats.empty()) return io::default_formats(mode);
  std::vector<io::DumpFormat> out;
  for (const auto& name : split(o.formats, ',')) {
    const auto f = io::parse_dump_format(name);
    if (!f) fail("--format", fmt::format("unknown format '{}' (png, exr, raw)", name));
    if (*f == io::DumpFormat::png && mode == Mode::scrgb)
      fail("--format", "scrgb has no PNG form (FP16 linear): use exr or raw");
    out.push_back(*f);
  }
  if (out.empty()) fail("--format", "no format given");
  return out;
}

std::string summary_text(const EncodedFrame& f, const io::DumpResult& dumps, bool json,
                         const std::vector<std::string>& notes) {
  if (json) {
    nlohmann::json j = io::sidecar_json(f, dumps.files);
    j["notes"] = notes;
    return j.dump(2);
  }
  std::string s = fmt::format("{} {}x{} {} peak {} cd/m2, paper white {} cd/m2", to_string(f.target.mode), f.width,
                              f.height, fourcc_name(f.drm_fourcc), f.target.peak_nits, f.target.paper_white_nits);
  if (f.target.is_hdr())
    s += fmt::format(", MaxCLL {:.0f}, MaxFALL {:.0f}", std::ceil(f.content_light.max_cll_nits),
                     std::ceil(f.content_light.max_fall_nits));
  s += "\n";
  for (const auto& [kind, path] : dumps.files) s += fmt::format("  {:8} {}\n", kind, path);
  for (const auto& n : notes) s += "  note: " + n + "\n";
  return s;
}

}  // namespace hdrd::cli

#include "daemon/output.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "encode/colour/transfer.hpp"

#if defined(HDRD_DISPLAY_AVAILABLE) && __has_include("display/displays.hpp")
#include "display/displays.hpp"
#define HDRD_HAVE_DISPLAYS 1
#endif

namespace hdrd::daemon {
namespace {

std::string fmt_nits(double v) { return fmt::format("{:.6g}", v); }

// CTA-861.3 carries whole cd/m2: round up so the metadata never understates the content.
long long ceil_nits(double nits) { return nits > 0 ? static_cast<long long>(std::ceil(nits - 1e-9)) : 0; }

}  // namespace

Result<DisplayTarget> resolve_display(const DisplaySpec& spec, std::vector<std::string>* warnings) {
  if (!spec.auto_detect && spec.edid_path.empty()) return spec.target;
#ifdef HDRD_HAVE_DISPLAYS
  auto profile = display::select_profile(spec.edid_path.empty() ? "auto" : "", spec.edid_path.string());
  if (!profile) {
    Error e = profile.error();
    if (e.field.empty()) e.field = spec.edid_path.empty() ? "display" : "display.edid";
    return e;
  }
  const auto has = [&](std::string_view f) { return std::find(spec.given.begin(), spec.given.end(), f) != spec.given.end(); };
  const DisplayTarget& req = spec.target;
  if (!*profile) {  // headless: nothing attached
    if (warnings) warnings->push_back("display auto: no display attached; using the mode's defaults");
    return req;
  }
  DisplayTarget t = default_target(has("mode") ? req.mode : (*profile)->mode);
  display::apply_profile(**profile, t, !has("mode"));
  // The request's explicit values win over the display's (REFERENCE.md §1.8 couplings kept).
  if (has("peak_nits")) t.peak_nits = req.peak_nits;
  if (has("black_nits")) t.black_nits = req.black_nits;
  const bool sdr = t.mode == Mode::sdr || t.mode == Mode::sdr_bt1886;
  if (has("paper_white_nits")) t.paper_white_nits = req.paper_white_nits;
  else if (sdr) t.paper_white_nits = t.peak_nits;
  t.ui_white_nits = has("ui_white_nits") ? req.ui_white_nits : t.paper_white_nits;
  t.sdr_white_nits = has("sdr_white_nits") ? req.sdr_white_nits : t.paper_white_nits;
  if (has("range")) t.range = req.range;
  if (has("sdr_curve")) t.sdr_curve = req.sdr_curve;
  if (has("bits")) t.bits = req.bits;
  if (auto ok = validate(t); !ok) {
    Error e = ok.error();
    e.code = "display.invalid";
    return e;
  }
  return t;
#else
  (void)warnings;
  return make_error("display.unavailable", "display queries are not available in this build", "display");
#endif
}

Result<EncodeSettings> build_encode_settings(const Request& r, const DisplayTarget& target,
                                             exposure::Mode default_exposure, int threads,
                                             std::vector<std::string>* warnings) {
  EncodeSettings s;
  s.target = target;
  s.exposure = r.exposure;
  if (!r.exposure_mode_given) s.exposure.mode = default_exposure;
  s.tone.curve = r.tone.curve;
  s.tone.params = r.tone.params;
  if (!r.tone.apply.empty()) {
    const auto a = tonemap::parse_apply(r.tone.apply);
    if (!a) return make_error("request.value", fmt::format("tone.apply: unknown value '{}'", r.tone.apply), "tone.apply");
    s.tone.apply = *a;
  }
  if (const auto g = parse_gamut_mapping(r.gamut)) s.gamut = *g;
  s.dither = r.dither;
  s.threads = threads;
  if (r.grade) {
    grade::GradeSettings gs;
    gs.lut_path = r.grade->lut.string();
    if (!r.grade->shaper.empty()) gs.shaper = grade::parse_shaper(r.grade->shaper);
    if (const auto p = grade::parse_placement(r.grade->placement)) gs.placement = *p;
    gs.trilinear = r.grade->trilinear;
    auto g = grade::load_grade(gs, target.peak_nits, warnings);
    if (!g) {
      Error e = g.error();
      if (e.field.empty()) e.field = "grade.lut";
      return e;
    }
    s.grade = *g;
  }
  if (r.ui) {
    auto overlay = r.ui->png.empty() ? io::read_overlay_png(r.ui->path, r.ui->premultiplied)
                                     : io::read_overlay_png_memory(r.ui->png, r.ui->premultiplied);
    if (!overlay) {
      Error e = overlay.error();
      e.field = r.ui->png.empty() ? "ui.path" : "ui.png_base64";
      return e;
    }
    s.ui.overlay = std::make_shared<const OverlayImage>(std::move(*overlay));
    s.ui.x = r.ui->x;
    s.ui.y = r.ui->y;
    s.ui.scale = r.ui->scale;
    s.ui.dim = r.ui->dim;
    s.ui.srgb_blend = r.ui->srgb_blend;
  }
  return s;
}

Result<std::vector<std::uint8_t>> frame_exr_bytes(const EncodedFrame& frame) {
  if (!frame.display_nits) return make_error("internal", "the encoder did not keep the display light for the EXR");
  const double white = frame.target.mode == Mode::scrgb ? transfer::kScrgbUnitNits : frame.target.paper_white_nits;
  Image scaled = *frame.display_nits;
  const float inv = static_cast<float>(1.0 / white);
  for (std::size_t i = 0; i < scaled.rgba.size(); ++i)
    if (i % 4 != 3) scaled.rgba[i] *= inv;
  io::ExrWriteOptions options;
  options.half = true;
  options.chromaticities = frame.target.container();
  options.white_luminance = white;
  options.attributes["mode"] = std::string(to_string(frame.target.mode));
  options.attributes["peak_nits"] = fmt_nits(frame.target.peak_nits);
  options.attributes["paper_white_nits"] = fmt_nits(frame.target.paper_white_nits);
  return io::encode_exr(scaled, options);
}

std::vector<std::pair<std::string, std::string>> frame_headers(const EncodedFrame& f) {
  const auto& t = f.target;
  std::vector<std::pair<std::string, std::string>> h = {
      {"X-Hdrd-Mode", std::string(to_string(t.mode))},
      {"X-Hdrd-Fourcc", fourcc_name(f.drm_fourcc)},
      {"X-Hdrd-Width", std::to_string(f.width)},
      {"X-Hdrd-Height", std::to_string(f.height)},
      {"X-Hdrd-Stride", std::to_string(f.stride_bytes)},
      {"X-Hdrd-Range", std::string(to_string(t.range))},
      {"X-Hdrd-Bits", std::to_string(t.bits)},
      {"X-Hdrd-Peak-Nits", fmt_nits(t.peak_nits)},
      {"X-Hdrd-Black-Nits", fmt_nits(t.black_nits)},
      {"X-Hdrd-Paper-White-Nits", fmt_nits(t.paper_white_nits)},
      {"X-Hdrd-MaxCLL", std::to_string(ceil_nits(f.content_light.max_cll_nits))},
      {"X-Hdrd-MaxFALL", std::to_string(ceil_nits(f.content_light.max_fall_nits))},
      {"X-Hdrd-Mastering",
       fmt::format("R{:.4f},{:.4f} G{:.4f},{:.4f} B{:.4f},{:.4f} W{:.4f},{:.4f} L{},{}", f.mastering.primaries.red.x,
                   f.mastering.primaries.red.y, f.mastering.primaries.green.x, f.mastering.primaries.green.y,
                   f.mastering.primaries.blue.x, f.mastering.primaries.blue.y, f.mastering.primaries.white.x,
                   f.mastering.primaries.white.y, fmt_nits(f.mastering.max_nits), fmt_nits(f.mastering.min_nits))},
      {"X-Hdrd-Target-Source", t.source},
  };
  if (f.settings.is_object()) {
    if (auto it = f.settings.find("tone_curve"); it != f.settings.end() && it->contains("name"))
      h.emplace_back("X-Hdrd-Tone-Curve", (*it)["name"].get<std::string>());
  }
  return h;
}

Result<Reply> frame_reply(const EncodedFrame& frame, OutputKind kind, const std::vector<std::string>& warnings) {
  Result<std::vector<std::uint8_t>> bytes = std::vector<std::uint8_t>{};
  switch (kind) {
    case OutputKind::png: bytes = io::encode_png(frame); break;
    case OutputKind::exr: bytes = frame_exr_bytes(frame); break;
    case OutputKind::raw: bytes = frame.data; break;
    case OutputKind::json_dump: return make_error("internal", "frame_reply cannot answer a dump");
  }
  if (!bytes) return bytes.error();
  Reply r;
  r.content_type = std::string(content_type(kind));
  r.body = std::make_shared<const std::string>(bytes->begin(), bytes->end());
  r.headers = frame_headers(frame);
  for (std::size_t i = 0; i < warnings.size() && i < 8; ++i)
    r.headers.emplace_back("X-Hdrd-Warning", warnings[i].substr(0, 200));
  return r;
}

Result<Reply> dump_reply(const EncodedFrame& frame, const std::filesystem::path& dump_dir, const std::string& name,
                         const std::vector<std::string>& formats, const std::vector<std::string>& warnings) {
  if (dump_dir.empty()) return make_error("path.forbidden", "no dump directory is configured ([paths] dump_dir)", "dump");
  std::vector<io::DumpFormat> fs;
  for (const auto& f : formats)
    if (auto d = io::parse_dump_format(f)) fs.push_back(*d);
  if (fs.empty()) fs = io::default_formats(frame.target.mode);
  auto dumps = io::write_dumps(frame, dump_dir / name, fs);
  if (!dumps) {
    Error e = dumps.error();
    if (e.code.rfind("io.", 0) != 0) e.code = "io." + e.code;
    return e;
  }
  nlohmann::json j = io::sidecar_json(frame, dumps->files);
  j["warnings"] = warnings;
  Reply r = Reply::json(200, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  r.headers = frame_headers(frame);
  return r;
}

bool needs_display_nits(const Request& request, OutputKind kind) {
  if (kind == OutputKind::exr) return true;
  const auto& f = request.formats;
  return request.dump && (f.empty() || std::find(f.begin(), f.end(), "exr") != f.end());
}

Result<Reply> answer_frame(const EncodedFrame& frame, const Request& request, OutputKind kind,
                           const std::filesystem::path& dump_dir, const std::string& dump_name,
                           const std::vector<std::string>& warnings) {
  return request.dump ? dump_reply(frame, dump_dir, dump_name, request.formats, warnings)
                      : frame_reply(frame, kind, warnings);
}

}  // namespace hdrd::daemon

// The display-mode suite: builds the frames (uniform paper white, Rec.709 primaries, an
// over-range ramp, patterns, rendered built-in scenes), encodes them for the mode and
// runs the check functions over them.
#include <chrono>
#include <cmath>
#include <filesystem>

#include <unistd.h>

#include <fmt/format.h>

#include "display/hdr_metadata.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/tonemap.hpp"
#include "patterns/patterns.hpp"
#include "patterns/selftest.hpp"
#include "shading/renderer.hpp"

namespace hdrd::patterns {
namespace {

Image uniform(int w, int h, color::Vec3 v) {
  Image img(w, h);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    img.rgba[i * 4] = float(v.x), img.rgba[i * 4 + 1] = float(v.y), img.rgba[i * 4 + 2] = float(v.z);
    img.rgba[i * 4 + 3] = 1;
  }
  return img;
}

// A frame as the checks get it: through SuiteOptions::tamper when a test sets one.
Result<EncodedFrame> delivered(Result<EncodedFrame> f, const SuiteOptions& o) {
  if (f && o.tamper) o.tamper(*f);
  return f;
}

// Relative input (1.0 = paper white; Rec.709 unless `to_working` says otherwise), manual
// exposure at 0 EV.
Result<EncodedFrame> encode_relative(const Image& img, const DisplayTarget& t, const std::string& curve,
                                     const SuiteOptions& o, bool keep_nits = false,
                                     const color::Mat3& to_working = color::to_working(color::Space::rec709),
                                     const UiSettings& ui = {}) {
  EncodeSettings s;
  s.target = t;
  s.tone.curve = curve;
  s.keep_display_nits = keep_nits;
  s.ui = ui;
  SceneInput in;
  in.image = &img;
  in.to_working = to_working;
  return delivered(encode_frame(in, s), o);
}

Check failed(std::string name, std::string source, const Error& e) {
  return Check{std::move(name), std::move(source), false, false, e.message};
}

void paper_white_checks(Report& r, const SuiteOptions& o) {
  const Image white = uniform(16, 16, {1, 1, 1});
  const bool claims_apply = r.target.peak_nits >= 2 * r.target.paper_white_nits;
  for (const auto& info : tonemap::curves()) {
    const std::string curve(info.name);
    if (curve != "clip" && !(info.keeps_reference_white && claims_apply)) continue;
    auto f = encode_relative(white, r.target, curve, o);
    r.checks.push_back(f ? check_paper_white(*f, curve) : failed("paper-white/" + curve, "encode", f.error()));
  }
  if (!claims_apply)
    r.checks.push_back(Check{"paper-white/keeps-reference-white-curves", "tonemap.hpp: the claim holds when peak >= 2 x paper white",
                             true, true, fmt::format("peak {} < 2 x paper white {}: only clip is checked", r.target.peak_nits,
                                                     r.target.paper_white_nits)});
}

void primaries_checks(Report& r, const SuiteOptions& o) {
  Image img(48, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 48; ++x) {
      float* p = img.px(x, y);
      p[x / 16] = 0.5f;  // red, green, blue thirds at half paper white
      p[3] = 1;
    }
  for (const std::string& curve : {std::string("clip"), std::string(tonemap::default_curve(r.target.mode))}) {
    auto f = encode_relative(img, r.target, curve, o);
    r.checks.push_back(f ? check_rec709_primaries(*f, curve) : failed("rec709-primaries/" + curve, "encode", f.error()));
  }
}

// A ramp from 1e-3 to 1e3 x paper white: the highest codes, the content light and the dumps.
void ramp_checks(Report& r, const SuiteOptions& o) {
  Image ramp(256, 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 256; ++x) {
      float* p = ramp.px(x, y);
      p[0] = p[1] = p[2] = float(std::pow(10.0, -3 + 6.0 * x / 255));
      if (y >= 8) p[1] *= 0.25f, p[2] *= 0.1f;  // a saturated half
      p[3] = 1;
    }
  for (const std::string& curve : {std::string("clip"), std::string(tonemap::default_curve(r.target.mode))}) {
    auto f = encode_relative(ramp, r.target, curve, o, true);
    if (!f) { r.checks.push_back(failed("peak/ramp-" + curve, "encode", f.error())); continue; }
    r.checks.push_back(check_peak(*f, "ramp-" + curve));
    r.checks.push_back(check_content_light(*f, "ramp-" + curve));
    if (curve != "clip") continue;
    if (r.target.mode == Mode::hdr10 || r.target.mode == Mode::hlg) {
      auto m = display::make_hdr_output_metadata(r.target.mode, f->mastering, f->content_light);
      if (!m) r.checks.push_back(failed("metadata-blob", "display/hdr_metadata", m.error()));
      else {
        const auto bytes = display::serialize(*m);
        r.checks.push_back(check_metadata_blob(*f, bytes));
      }
    }
    if (r.target.mode != Mode::scrgb) {
      auto png = io::encode_png(*f);
      auto info = png ? io::read_png_info_memory(*png) : Result<io::PngInfo>(png.error());
      r.checks.push_back(info ? check_png(*f, *info) : failed("png-chunks", "io", info.error()));
    }
    const auto dir = std::filesystem::temp_directory_path() / fmt::format("hdrd-selftest-{}", ::getpid());
    std::filesystem::create_directories(dir);
    auto dumps = io::write_dumps(*f, dir / "ramp", {io::DumpFormat::exr});
    auto exr = dumps ? io::read_exr(dumps->files.at("exr")) : Result<io::ExrImage>(dumps.error());
    r.checks.push_back(exr ? check_exr(*f, *exr) : failed("exr-attributes", "io", exr.error()));
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
}

// Saturated Rec.2020 colours up to the peak and beyond: the dump must be what the display
// shows from the codes, which for HLG is less than the [0, peak] cube (issue 15 item 1).
void volume_checks(Report& r, const SuiteOptions& o) {
  const color::Vec3 hues[] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}, {1, 1, 0}, {1, 0.3, 0}, {0, 0.5, 1}};
  const double levels[] = {0.25, 0.5, 0.8, 1.0, 2.0};  // x peak / paper white
  Image img(static_cast<int>(std::size(hues) * std::size(levels)), 4);
  const double w = r.target.peak_nits / r.target.paper_white_nits;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const color::Vec3 h = hues[static_cast<std::size_t>(x) % std::size(hues)] *
                            (levels[static_cast<std::size_t>(x) / std::size(hues)] * w);
      float* p = img.px(x, y);
      p[0] = float(h.x), p[1] = float(h.y), p[2] = float(h.z), p[3] = 1;
    }
  for (const std::string& curve : {std::string("clip"), std::string(tonemap::default_curve(r.target.mode))}) {
    auto f = encode_relative(img, r.target, curve, o, true, color::Mat3::identity());
    r.checks.push_back(f ? check_display_volume(*f, curve) : failed("display-volume/" + curve, "encode", f.error()));
  }
}

// Every scalar curve's fast-path tables at and around the kinks found in it (issue 15 item 2).
void kink_checks(Report& r, const SuiteOptions& o) {
  const tonemap::Display d{r.target.peak_nits, r.target.black_nits, r.target.paper_white_nits};
  for (const auto& info : tonemap::curves()) {
    if (!info.scalar) continue;  // RGB operators run the per-pixel reference: no tables
    const std::string name(info.name);
    auto curve = tonemap::prepare(name, d);
    if (!curve) { r.checks.push_back(failed("tone-kinks/" + name, "tonemap", curve.error())); continue; }
    const auto& c = **curve;
    const auto kinks = tonemap::find_kinks([&](double x) { return c.map(x); }, 1e-4, 1e4);
    std::vector<double> xs;
    for (int i = 0; i <= 48; ++i) xs.push_back(std::pow(10.0, -3 + 6.0 * i / 48));
    for (double k : kinks)
      for (int j = -12; j <= 12; ++j) xs.push_back(k * (1 + 4e-4 * j));
    Image img(static_cast<int>(xs.size()), 1);
    for (std::size_t i = 0; i < xs.size(); ++i) {
      float* p = img.px(static_cast<int>(i), 0);
      p[0] = p[1] = p[2] = float(xs[i]), p[3] = 1;
    }
    // The check compares with the curve at the float the encoder read.
    for (std::size_t i = 0; i < xs.size(); ++i) xs[i] = img.px(static_cast<int>(i), 0)[0];
    auto f = encode_relative(img, r.target, name, o, false, color::Mat3::identity());
    r.checks.push_back(f ? check_tone_kinks(*f, c, xs, name, kinks) : failed("tone-kinks/" + name, "encode", f.error()));
  }
}

// A black frame's content light level, everywhere it is carried (issue 15 item 5).
void black_frame_checks(Report& r, const SuiteOptions& o) {
  if (!r.target.is_hdr()) return;
  auto f = encode_relative(Image(16, 16), r.target, "clip", o);
  if (!f) { r.checks.push_back(failed("black-frame-metadata", "encode", f.error())); return; }
  const nlohmann::json sidecar = io::sidecar_json(*f, {});
  std::optional<io::PngInfo> png;
  std::vector<std::uint8_t> blob;
  if (r.target.mode != Mode::scrgb) {
    auto bytes = io::encode_png(*f);
    auto info = bytes ? io::read_png_info_memory(*bytes) : Result<io::PngInfo>(bytes.error());
    if (!info) { r.checks.push_back(failed("black-frame-metadata", "png", info.error())); return; }
    png = std::move(*info);
    auto m = display::make_hdr_output_metadata(r.target.mode, f->mastering, f->content_light);
    if (!m) { r.checks.push_back(failed("black-frame-metadata", "display/hdr_metadata", m.error())); return; }
    const auto b = display::serialize(*m);
    blob.assign(b.begin(), b.end());
  }
  r.checks.push_back(check_black_frame_metadata(*f, sidecar, png ? &*png : nullptr, blob));
}

// SDR content (the UI) decoded with each SDR content EOTF (issue 15 item 9).
void sdr_content_checks(Report& r, const SuiteOptions& o) {
  std::vector<int> codes;
  for (double v : sdr_shadow_signals()) codes.push_back(static_cast<int>(std::lround(v * 255)));
  codes.push_back(128);
  codes.push_back(255);
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = static_cast<int>(codes.size()) * 4;
  overlay->height = 4;
  for (int y = 0; y < overlay->height; ++y)
    for (int x = 0; x < overlay->width; ++x) {
      const float v = codes[static_cast<std::size_t>(x / 4)] / 255.0f;
      overlay->rgba.insert(overlay->rgba.end(), {v, v, v, 1.0f});
    }
  UiSettings ui;
  ui.overlay = overlay;
  for (SdrEotf e : kSdrShadowRows) {
    DisplayTarget t = r.target;
    t.sdr_content_eotf = e;
    auto f = encode_relative(Image(overlay->width, overlay->height), t, "clip", o, false,
                             color::to_working(color::Space::rec709), ui);
    r.checks.push_back(f ? check_sdr_content(*f, codes, t.ui_white_nits)
                         : failed("sdr-content/" + std::string(to_string(e)), "encode", f.error()));
  }
}

void pattern_checks(Report& r, const SuiteOptions& so) {
  PatternOptions o;
  o.width = 96, o.height = 54, o.labels = false;
  for (double level : {r.target.paper_white_nits, r.target.peak_nits * 0.5, r.target.peak_nits}) {
    o.level_nits = level;
    auto f = delivered(make_pattern("window", r.target, o, false), so);
    if (!f) { r.checks.push_back(failed("window", "pattern", f.error())); continue; }
    Check c = check_window(*f, level);
    c.name = fmt::format("window/{:g}", level);
    r.checks.push_back(c);
    r.checks.push_back(check_peak(*f, fmt::format("window-{:g}", level)));
  }
  o.level_nits = 0;
  for (const char* name : {"pq-ramp", "clipping", "near-black", "sdr-grey", "sdr-shadows"}) {
    auto f = delivered(make_pattern(name, r.target, o, false), so);
    if (!f) { r.checks.push_back(failed(std::string("pattern/") + name, "pattern", f.error())); continue; }
    r.checks.push_back(check_peak(*f, name));
    r.checks.push_back(check_content_light(*f, name));
    if (std::string_view(name) == "sdr-shadows") r.checks.push_back(check_sdr_shadows(*f));
  }
}

void render_checks(Report& r, const SuiteOptions& o) {
  auto renderer = shading::Renderer::create();
  if (!renderer) {
    r.checks.push_back(Check{"render", "shading: offscreen GL", true, true,
                             "skipped: no GL context (" + renderer.error().message + ")"});
    return;
  }
  for (const char* scene : {"material-grid", "fresnel", "furnace", "hdr", "underwater"}) {
    shading::RenderRequest q;
    q.scene = scene, q.width = o.render_width, q.height = o.render_height, q.samples = 1;
    auto img = (*renderer)->render(q);
    if (!img) { r.checks.push_back(failed(std::string("render/") + scene, "shading", img.error())); continue; }
    EncodeSettings s;
    s.target = r.target;
    s.exposure.mode = exposure::Mode::histogram;
    SceneInput in;
    in.image = &img->scene_nits;
    in.units = InputUnits::absolute;
    auto f = delivered(encode_frame(in, s), o);
    if (!f) { r.checks.push_back(failed(std::string("render/") + scene, "encode", f.error())); continue; }
    r.checks.push_back(check_peak(*f, std::string("scene-") + scene));
    r.checks.push_back(check_content_light(*f, std::string("scene-") + scene));
  }
}

}  // namespace

bool Report::passed() const { return failed_count() == 0; }

int Report::failed_count() const {
  int n = 0;
  for (const auto& c : checks) n += (!c.passed && !c.skipped) ? 1 : 0;
  return n;
}

nlohmann::json Report::to_json() const {
  nlohmann::json j = {{"mode", mode},
                      {"peak_nits", target.peak_nits},
                      {"paper_white_nits", target.paper_white_nits},
                      {"passed", passed()},
                      {"failed", failed_count()},
                      {"seconds", seconds},
                      {"checks", nlohmann::json::array()}};
  for (const auto& c : checks)
    j["checks"].push_back({{"name", c.name}, {"source", c.source}, {"passed", c.passed}, {"skipped", c.skipped},
                           {"detail", c.detail}});
  return j;
}

std::string suite_modes_text() {
  std::string s;
  for (auto m : mode_names()) s += (s.empty() ? "" : ", ") + std::string(m);
  return s;
}

Result<DisplayTarget> suite_target(std::string_view mode, std::optional<double> peak) {
  const auto parsed = parse_mode(mode);
  if (!parsed) return make_error("selftest.mode", fmt::format("unknown mode '{}' ({})", mode, suite_modes_text()), "mode");
  // Through the resolver, as every front end: paper white follows a peak below it.
  LevelSettings asked;
  asked.peak_nits = peak;
  return resolve_target(*parsed, {}, asked);
}

Report run_suite(const DisplayTarget& target, std::string_view mode_name, const SuiteOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Report r;
  r.mode = std::string(mode_name);
  r.target = target;
  paper_white_checks(r, o);
  primaries_checks(r, o);
  ramp_checks(r, o);
  volume_checks(r, o);
  kink_checks(r, o);
  black_frame_checks(r, o);
  sdr_content_checks(r, o);
  for (auto& c : check_curves_monotonic(target)) r.checks.push_back(std::move(c));
  pattern_checks(r, o);
  if (o.render) render_checks(r, o);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace hdrd::patterns

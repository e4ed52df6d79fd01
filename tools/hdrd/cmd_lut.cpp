// hdrd lut: the grading-LUT tools. export-identity / import (Selan's identity-strip
// workflow, GPU Gems 2 ch. 24), info, bake (a tone curve and shaper into a .cube, with the
// measured bake error) and apply (a scene-referred LUT on an EXR).
#include <nlohmann/json.hpp>

#include <cmath>
#include <map>

#include "encode/grade/grade.hpp"
#include "encode/io/io.hpp"
#include "encode/grade/lut.hpp"
#include "encode/parallel.hpp"
#include "encode/grade/ocio.hpp"
#include "encode/tone/tonemap.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

void warn_all(const std::vector<std::string>& warnings, const CommonOptions& c) {
  if (c.quiet) return;
  for (const auto& w : warnings) std::fprintf(stderr, "hdrd: warning: %s\n", w.c_str());
}

lut::ShaperSpec shaper_arg(const std::string& text) { return lut::parse_shaper_spec(text).value(); }

std::string strip_text(int size, const lut::ShaperSpec& shaper) {
  return fmt::format("hdrd identity strip: size={} shaper={} layout=slices-along-blue", size, lut::to_string(shaper));
}

// ---- export-identity -------------------------------------------------------------------
struct ExportOptions {
  CommonOptions common;
  int size = 33;
  std::string shaper = "pq", output;
};

void run_export(const ExportOptions& o) {
  const auto shaper = shaper_arg(o.shaper);
  if (o.size < lut::kMin3DSize || o.size > lut::kMaxStripSize)
    throw CliError(fmt::format("--size {} is outside {}..{} (the strip is size^2 pixels wide)", o.size,
                               lut::kMin3DSize, lut::kMaxStripSize));
  lut::write_strip_png(lut::identity_strip(o.size), o.output, strip_text(o.size, shaper)).value();
  const nlohmann::json j = {{"output", o.output}, {"size", o.size}, {"width", o.size * o.size},
                            {"height", o.size}, {"bits", 16}, {"shaper", lut::to_string(shaper)}};
  if (o.common.json) return print_out(j.dump(2));
  print_out(fmt::format("wrote {} ({}x{} 16-bit identity strip, shaper {}); grade it in an image editor, then run\n"
                        "  hdrd lut import {} -o look.cube",
                        o.output, o.size * o.size, o.size, lut::to_string(shaper), o.output));
}

// ---- import ------------------------------------------------------------------------------
struct ImportOptions {
  CommonOptions common;
  std::string input, output, shaper, title;
};

std::optional<lut::ShaperSpec> shaper_from_strip_text(const std::string& text) {
  const auto at = text.find("shaper=");
  if (at == std::string::npos) return std::nullopt;
  const auto end = text.find(' ', at);
  auto s = lut::parse_shaper_spec(text.substr(at + 7, end == std::string::npos ? end : end - at - 7));
  return s.ok() ? std::optional(*s) : std::nullopt;
}

void run_import(const ImportOptions& o) {
  std::vector<std::string> warnings;
  std::string text;
  const auto strip = lut::read_strip_png(o.input, &text, &warnings).value();
  std::optional<lut::ShaperSpec> shaper = shaper_from_strip_text(text);
  if (!o.shaper.empty()) shaper = shaper_arg(o.shaper);
  if (!shaper) {
    warnings.push_back(fmt::format("{}: the editor dropped hdrd's text chunk and no --shaper was given: recording pq",
                                   o.input));
    shaper = lut::ShaperSpec::defaults(grade::Shaper::pq);
  }
  lut::CubeFile cube;
  cube.lut3d = lut::lut_from_strip(strip);
  cube.title = o.title;
  cube.comments = {fmt::format("Imported by hdrd from {}", o.input), lut::shaper_comment(*shaper)};
  const auto check = lut::detect_spatial_edit(*cube.lut3d);
  if (check.suspected)
    warnings.push_back(fmt::format("{}: spatial edit suspected (blur, sharpen or resize): slice edges moved toward "
                                   "their neighbours by {:.1f} % / {:.1f} %; only colour edits make a valid LUT",
                                   o.input, 100 * check.pull_right, 100 * check.pull_left));
  lut::write_cube(cube, o.output).value();
  warn_all(warnings, o.common);
  const nlohmann::json j = {{"input", o.input},
                            {"output", o.output},
                            {"size", strip.size},
                            {"shaper", lut::to_string(*shaper)},
                            {"spatial_edit_suspected", check.suspected},
                            {"edge_pull", {check.pull_right, check.pull_left}},
                            {"interior_curvature", check.noise},
                            {"warnings", warnings}};
  if (o.common.json) return print_out(j.dump(2));
  print_out(fmt::format("wrote {} ({}^3, shaper {})", o.output, strip.size, lut::to_string(*shaper)));
}

// ---- info --------------------------------------------------------------------------------
struct InfoOptions {
  CommonOptions common;
  std::string input;
};

nlohmann::json table_json(const auto& lut) {
  float lo = INFINITY, hi = -INFINITY;
  for (float v : lut.rgb) lo = std::min(lo, v), hi = std::max(hi, v);
  return {{"size", lut.size}, {"domain_min", lut.domain.min}, {"domain_max", lut.domain.max}, {"min", lo}, {"max", hi}};
}

void run_info(const InfoOptions& o) {
  nlohmann::json j = {{"file", o.input}};
  std::string ext = std::filesystem::path(o.input).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".cube") {
    ocio::file_transform(o.input, lut::Interpolation::tetrahedral).value();
    j["format"] = "read by OpenColorIO " + ocio::version();
    if (o.common.json) return print_out(j.dump(2));
    return print_out(fmt::format("{}: a LUT OpenColorIO {} reads (applied through its FileTransform)", o.input,
                                 ocio::version()));
  }
  const auto cube = lut::read_cube(o.input).value();
  j["format"] = "cube";
  j["title"] = cube.title;
  j["comments"] = cube.comments;
  if (cube.lut1d) j["lut1d"] = table_json(*cube.lut1d);
  if (cube.lut3d) {
    j["lut3d"] = table_json(*cube.lut3d);
    const auto id = lut::Lut3D::identity(cube.lut3d->size);
    double dev = 0;
    for (std::size_t i = 0; i < id.rgb.size(); ++i) dev = std::max(dev, double(std::fabs(id.rgb[i] - cube.lut3d->rgb[i])));
    j["lut3d"]["max_deviation_from_identity"] = dev;
  }
  if (auto s = lut::shaper_from_comments(cube.comments)) j["shaper"] = lut::to_string(*s);
  if (auto b = lut::bake_record_from_comments(cube.comments))
    j["baked"] = {{"peak_nits", b->peak_nits}, {"paper_white_nits", b->paper_white_nits}, {"curve", b->curve},
                  {"apply", b->apply}};
  if (o.common.json) return print_out(j.dump(2));
  std::string s = fmt::format("{}: .cube{}\n", o.input, cube.title.empty() ? "" : " \"" + cube.title + "\"");
  if (cube.lut1d) s += fmt::format("  1D table: {} entries, values {} .. {}\n", cube.lut1d->size,
                                   j["lut1d"]["min"].get<float>(), j["lut1d"]["max"].get<float>());
  if (cube.lut3d)
    s += fmt::format("  3D table: {}^3, domain [{}, {}, {}] .. [{}, {}, {}], values {} .. {}, max deviation from "
                     "identity {:.6f}\n",
                     cube.lut3d->size, cube.lut3d->domain.min[0], cube.lut3d->domain.min[1], cube.lut3d->domain.min[2],
                     cube.lut3d->domain.max[0], cube.lut3d->domain.max[1], cube.lut3d->domain.max[2],
                     j["lut3d"]["min"].get<float>(), j["lut3d"]["max"].get<float>(),
                     j["lut3d"]["max_deviation_from_identity"].get<double>());
  if (j.contains("shaper")) s += fmt::format("  shaper: {}\n", j["shaper"].get<std::string>());
  if (j.contains("baked"))
    s += fmt::format("  baked tone curve: {} for {} cd/m2 peak, paper white {} cd/m2 (use --grade baked)\n",
                     j["baked"]["curve"].get<std::string>(), j["baked"]["peak_nits"].get<double>(),
                     j["baked"]["paper_white_nits"].get<double>());
  print_out(s);
}

// ---- bake --------------------------------------------------------------------------------
struct BakeOptions {
  CommonOptions common;
  std::string curve, apply, shaper = "pq", output, look, look_placement = "scene", title;
  std::vector<std::string> params;
  double peak = 1000, paper_white = 203;
  int size = 65;
};

void run_bake(const BakeOptions& o) {
  lut::BakeRequest rq;
  rq.curve = o.curve.empty() ? std::string(tonemap::default_curve(Mode::hdr10)) : o.curve;
  for (const auto& kv : o.params) {
    const auto eq = kv.find('=');
    char* end = nullptr;
    const double v = eq == std::string::npos ? 0 : std::strtod(kv.c_str() + eq + 1, &end);
    if (eq == std::string::npos || !end || *end) throw CliError("--param wants NAME=NUMBER, got '" + kv + "'");
    rq.params[kv.substr(0, eq)] = v;
  }
  if (!o.apply.empty()) {
    rq.apply = tonemap::parse_apply(o.apply);
    if (!rq.apply) throw CliError("--apply must be per-channel, max-rgb, luminance or rgb");
  }
  rq.display = {o.peak, 0, o.paper_white};
  rq.shaper = shaper_arg(o.shaper);
  rq.size = o.size;
  rq.title = o.title;
  std::vector<std::string> warnings;
  if (!o.look.empty()) {
    grade::GradeSettings gs;
    gs.lut_path = o.look;
    const auto p = grade::parse_placement(o.look_placement);
    if (!p || *p == grade::Placement::baked) throw CliError("--look-placement must be scene or display");
    gs.placement = *p;
    rq.look = grade::load_grade(gs, o.peak, &warnings).value();
  }
  if (o.common.quiet) set_progress_enabled(false);
  progress("baking {} for {} cd/m2 into a {}^3 LUT", rq.curve, o.peak, o.size);
  const auto result = lut::bake_tone_curve(rq).value();
  lut::write_cube(result.cube, o.output).value();
  warn_all(warnings, o.common);
  const auto& e = result.error;
  const nlohmann::json j = {
      {"output", o.output}, {"curve", rq.curve}, {"peak_nits", o.peak}, {"paper_white_nits", o.paper_white},
      {"shaper", lut::to_string(rq.shaper)}, {"size", o.size},
      {"bake_error", {{"max_pq", e.max_pq}, {"mean_pq", e.mean_pq}, {"max_code10", e.max_code10},
                      {"samples", e.samples}, {"worst_input", e.worst_input}}},
      {"warnings", warnings}};
  if (o.common.json) return print_out(j.dump(2));
  print_out(fmt::format("wrote {}: {} for {} cd/m2 (paper white {}), shaper {}, {}^3\n"
                        "bake error against the analytic curve over {} samples: max {:.2e} PQ ({:.2f} 10-bit codes), "
                        "mean {:.2e} PQ\nuse it with: hdrd encode ... --lut {} --grade baked --peak {}",
                        o.output, rq.curve, o.peak, o.paper_white, lut::to_string(rq.shaper), o.size, e.samples,
                        e.max_pq, e.max_code10, e.mean_pq, o.output, o.peak));
}

// ---- apply -------------------------------------------------------------------------------
struct ApplyOptions {
  CommonOptions common;
  std::string input, output, lut, shaper;
  bool trilinear = false;
};

void run_apply(const ApplyOptions& o) {
  grade::GradeSettings gs;
  gs.lut_path = o.lut;
  gs.placement = grade::Placement::scene;
  gs.trilinear = o.trilinear;
  if (!o.shaper.empty()) {
    gs.shaper = grade::parse_shaper(o.shaper);
    if (!gs.shaper) throw CliError("--lut-shaper must be pq, log2, sqrt, sqrt-sqrt or none");
  }
  std::vector<std::string> warnings;
  const auto g = grade::load_grade(gs, 1000, &warnings).value();
  auto exr = io::read_exr(o.input).value();
  Image& img = exr.image;
  const color::Mat3 to_w = exr.to_working();
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    float* p = &img.rgba[4 * i];
    const color::Vec3 w = to_w * color::Vec3{p[0], p[1], p[2]};
    p[0] = float(w.x), p[1] = float(w.y), p[2] = float(w.z);
  }
  const std::size_t row = std::size_t(img.width);
  parallel_for(std::size_t(img.height), 0, 8, [&](std::size_t y0, std::size_t y1) {
    g->apply(img.rgba.data() + 4 * row * y0, row * (y1 - y0));
  });
  io::ExrWriteOptions wo;
  wo.half = false;
  wo.chromaticities = color::kRec2020;
  wo.white_luminance = exr.white_luminance;
  wo.attributes["grade"] = g->describe().dump();
  io::write_exr(o.output, img, wo).value();
  warn_all(exr.warnings, o.common);
  warn_all(warnings, o.common);
  const nlohmann::json j = {{"input", o.input}, {"output", o.output}, {"grade", g->describe()},
                            {"width", img.width}, {"height", img.height}, {"warnings", warnings}};
  print_out(o.common.json ? j.dump(2) : fmt::format("wrote {} (linear Rec.2020, graded with {})", o.output, o.lut));
}

// ---- setup -------------------------------------------------------------------------------
void setup(CLI::App& root) {
  auto* lut = root.add_subcommand("lut", "Grading LUTs: identity strips, info, baking tone curves, applying");
  lut->require_subcommand(1);
  lut->footer(
      "Examples:\n"
      "  hdrd lut export-identity --size 33 --shaper pq -o strip.png\n"
      "  hdrd lut import strip.png -o look.cube\n"
      "  hdrd lut info look.cube --json\n"
      "  hdrd lut bake --curve bt2390 --peak 1000 --size 65 -o baked1000.cube\n"
      "  hdrd lut apply in.exr --lut look.cube --lut-shaper pq -o graded.exr\n"
      "Run 'hdrd lut SUBCOMMAND --help' for each one's options.");

  auto ex = std::make_shared<ExportOptions>();
  auto* e = lut->add_subcommand("export-identity", "Write the sliced identity LUT as a 16-bit PNG strip to grade");
  e->add_option("--size", ex->size, "Lattice points per axis (2-128; the strip is size^2 x size)");
  e->add_option("--shaper", ex->shaper, "Shaper the LUT will be used with: pq, log2[:LO:HI], sqrt[:MAX], "
                                        "sqrt-sqrt[:MAX] (recorded in the PNG and the imported .cube)");
  e->add_option("-o,--output", ex->output, "Output PNG")->required();
  add_common_options(*e, ex->common);
  e->footer("Examples:\n  hdrd lut export-identity --size 33 --shaper pq -o strip.png\n"
            "  hdrd lut export-identity --size 17 --shaper log2:-10:8 -o strip17.png --json");
  e->callback([ex] { run_export(*ex); });

  auto im = std::make_shared<ImportOptions>();
  auto* i = lut->add_subcommand("import", "Turn an edited identity strip back into a .cube (warns on blur)");
  i->add_option("input", im->input, "Edited strip PNG (16-bit RGB; 8-bit works with a warning)")->required();
  i->add_option("-o,--output", im->output, "Output .cube")->required();
  i->add_option("--shaper", im->shaper, "Shaper to record (default: the one export-identity stored in the PNG)");
  i->add_option("--title", im->title, "TITLE for the .cube");
  add_common_options(*i, im->common);
  i->footer("Examples:\n  hdrd lut import strip.png -o look.cube\n  hdrd lut import strip.png -o look.cube --json");
  i->callback([im] { run_import(*im); });

  auto in = std::make_shared<InfoOptions>();
  auto* f = lut->add_subcommand("info", "Describe a LUT file (.cube in detail; other formats through OpenColorIO)");
  f->add_option("file", in->input, "LUT file")->required();
  add_common_options(*f, in->common);
  f->footer("Examples:\n  hdrd lut info look.cube\n  hdrd lut info film.spi3d --json");
  f->callback([in] { run_info(*in); });

  auto bk = std::make_shared<BakeOptions>();
  auto* b = lut->add_subcommand("bake", "Bake a tone curve (+ shaper, + optional look) into one .cube for a peak");
  b->add_option("--curve", bk->curve, "Tone curve (hdrd tonemap --list; default: the HDR10 default)");
  b->add_option("--param", bk->params, "Curve parameter NAME=VALUE (repeatable)");
  b->add_option("--apply", bk->apply, "per-channel, max-rgb, luminance or rgb (default: the curve's)");
  b->add_option("--peak", bk->peak, "Display peak the LUT is baked for, cd/m2 (recorded in the file)");
  b->add_option("--paper-white", bk->paper_white, "Paper white, cd/m2");
  b->add_option("--shaper", bk->shaper, "Input shaper: pq, log2[:LO:HI], sqrt[:MAX], sqrt-sqrt[:MAX]");
  b->add_option("--size", bk->size, "Lattice points per axis (2-256)");
  b->add_option("--look", bk->look, "A look LUT to bake in as well");
  b->add_option("--look-placement", bk->look_placement, "scene (before the curve) or display (after it)");
  b->add_option("--title", bk->title, "TITLE for the .cube");
  b->add_option("-o,--output", bk->output, "Output .cube")->required();
  add_common_options(*b, bk->common);
  b->footer("Examples:\n  hdrd lut bake --curve bt2390 --peak 1000 -o baked1000.cube\n"
            "  hdrd lut bake --curve aces-ocio-hdr-1000 --peak 1000 --size 33 --shaper log2 -o aces.cube --json\n"
            "  hdrd lut bake --peak 600 --look teal.cube --look-placement display -o teal600.cube");
  b->callback([bk] { run_bake(*bk); });

  auto ap = std::make_shared<ApplyOptions>();
  auto* a = lut->add_subcommand("apply", "Apply a scene-referred LUT to an EXR (writes linear Rec.2020 float EXR)");
  a->add_option("input", ap->input, "Input EXR (relative scene values)")->required();
  a->add_option("--lut", ap->lut, "LUT file (.cube or any OpenColorIO format)")->required();
  a->add_option("--lut-shaper", ap->shaper, "pq (default), log2, sqrt, sqrt-sqrt, none");
  a->add_flag("--trilinear", ap->trilinear, "Trilinear instead of tetrahedral interpolation");
  a->add_option("-o,--output", ap->output, "Output EXR")->required();
  add_common_options(*a, ap->common);
  a->footer("Examples:\n  hdrd lut apply ../shared/fixtures/exr/Desk.exr --lut look.cube -o graded.exr\n"
            "  hdrd lut apply in.exr --lut film.spi3d --lut-shaper log2 -o out.exr --json");
  a->callback([ap] { run_apply(*ap); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("lut", 70, &hdrd::cli::setup)

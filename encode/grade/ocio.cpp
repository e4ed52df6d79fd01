// OpenColorIO 2.1.2 glue (platform notes §3): processors from Config::CreateRaw for
// files and built-ins, configs for looks and display/views, and the built-in ACES output
// transforms as tone curves. OCIO exceptions become one-line hdrd::Error messages.
#include "encode/grade/ocio.hpp"

#include <OpenColorIO/OpenColorIO.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <optional>
#include <sstream>

#include "encode/colour/color.hpp"
#include "encode/tone/tonemap.hpp"
#include "encode/io/private_copy.hpp"
#include "encode/parallel.hpp"

namespace OCIO = OCIO_NAMESPACE;

namespace hdrd::ocio {

struct Processor::Impl {
  OCIO::ConstCPUProcessorRcPtr cpu;
};

namespace {

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  s.erase(std::unique(s.begin(), s.end(), [](char a, char b) { return a == ' ' && b == ' '; }), s.end());
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// OCIO logs interpolation fallbacks and similar to stderr; hdrd reports through its own
// warnings instead, so OCIO's log is dropped unless HDRD_OCIO_LOG is set.
void quiet_logging() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (!std::getenv("HDRD_OCIO_LOG")) OCIO::SetLoggingLevel(OCIO::LOGGING_LEVEL_NONE);
  });
}

Processor make_processor(const OCIO::ConstProcessorRcPtr& p) {
  auto impl = std::make_shared<Processor::Impl>();
  impl->cpu = p->getDefaultCPUProcessor();
  return Processor(std::move(impl));
}

// 4x4 row-major matrix for OCIO::MatrixTransform from a 3x3, scaled.
OCIO::MatrixTransformRcPtr matrix_transform(const color::Mat3& m, double scale = 1.0) {
  std::array<double, 16> m44{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m44[r * 4 + c] = m.m[r][c] * scale;
  m44[15] = 1.0;
  auto t = OCIO::MatrixTransform::Create();
  t->setMatrix(m44.data());
  return t;
}

OCIO::BuiltinTransformRcPtr builtin(const char* style, bool inverse = false) {
  auto t = OCIO::BuiltinTransform::Create();
  t->setStyle(style);
  if (inverse) t->setDirection(OCIO::TRANSFORM_DIR_INVERSE);
  return t;
}

constexpr const char* kAp0ToXyz = "UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD";

}  // namespace

std::string version() { return OCIO::GetVersion(); }

lut::Rgb Processor::apply(lut::Rgb rgb) const {
  impl_->cpu->applyRGB(rgb.data());
  return rgb;
}

void Processor::apply_rgba(float* rgba, std::size_t pixels, int threads) const {
  parallel_for(pixels, threads, 1 << 14, [&](std::size_t begin, std::size_t end) {
    OCIO::PackedImageDesc desc(rgba + 4 * begin, static_cast<long>(end - begin), 1, 4);
    impl_->cpu->apply(desc);
  });
}

namespace {

// The name a copy of `name` gets in a private directory: its file name alone (OpenColorIO
// chooses the reader by the extension).
std::filesystem::path copy_name(const std::filesystem::path& name) {
  auto file = name.filename();
  return file.empty() || file == "." || file == ".." ? std::filesystem::path("lut") : file;
}

// A LUT's bytes, read through the file model (its refusals keep their codes; a missing
// file is grade.file naming the LUT).
Result<std::string> read_lut(const io::InputFiles& files, const std::filesystem::path& path) {
  auto bytes = files.read(path, io::kMaxInputFileBytes);
  if (bytes) return bytes;
  Error e = io::reader_error(bytes.error(), "grade.file", "grade.file", "lut");
  if (e.code == "grade.file") e.message = fmt::format("{}: no such LUT file ({})", path.string(), bytes.error().message);
  return e;
}

}  // namespace

Result<Processor> file_transform(std::string_view bytes, const std::filesystem::path& name, lut::Interpolation interp) {
  quiet_logging();
  auto copies = io::PrivateCopies::create();
  if (!copies) return copies.error();
  auto copy = copies->add(copy_name(name), bytes);
  if (!copy) return copy.error();
  try {
    OCIO::ClearAllCaches();  // OCIO caches files by path; a rewritten file must be re-read
    auto config = OCIO::Config::CreateRaw();
    auto ft = OCIO::FileTransform::Create();
    ft->setSrc(copy->c_str());
    ft->setInterpolation(interp == lut::Interpolation::tetrahedral ? OCIO::INTERP_TETRAHEDRAL : OCIO::INTERP_LINEAR);
    return make_processor(config->getProcessor(ft));  // reads the copy now; the copy may go
  } catch (const std::exception& e) {
    std::string why = one_line(e.what());
    // OpenColorIO's message names the private copy: name the user's file instead.
    for (std::size_t at; (at = why.find(copy->string())) != std::string::npos;) why.replace(at, copy->string().size(), name.string());
    return make_error("grade.format", fmt::format("{}: OpenColorIO cannot read it: {}", name.string(), why), "lut");
  }
}

Result<Processor> file_transform(const std::filesystem::path& path, lut::Interpolation interp) {
  auto bytes = read_lut(io::InputFiles{}, path);
  if (!bytes) return bytes.error();
  return file_transform(*bytes, path, interp);
}

// ---- Configs ---------------------------------------------------------------------------
namespace {

constexpr const char* kWorkingName = "hdrd linear Rec.2020 (working)";

std::string join_names(int count, const std::function<const char*(int)>& name) {
  std::string out;
  for (int i = 0; i < count; ++i) out += (out.empty() ? "" : ", ") + std::string(name(i));
  return out.empty() ? "none" : out;
}

std::string colour_space_names(const OCIO::Config& c) {
  return join_names(c.getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL), [&](int i) {
    return c.getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL, i);
  });
}

// A config named by the request is read through the file model (`files`); $OCIO is the
// admin's own. OpenColorIO then opens the LUTs the config names itself.
Result<OCIO::ConstConfigRcPtr> open_config(const std::string& explicit_path, std::string& used, const io::InputFiles& files) {
  used = explicit_path;
  if (used.empty())
    if (const char* env = std::getenv("OCIO")) used = env;
  if (used.empty())
    return make_error("grade.ocio", "no OpenColorIO config: pass --ocio-config FILE or set $OCIO", "ocio_config");
  auto text = (explicit_path.empty() ? io::InputFiles{} : files).read(used, std::size_t(64) << 20);
  if (!text) {
    Error e = io::reader_error(text.error(), "grade.ocio", "grade.ocio", "ocio_config");
    e.message = fmt::format("OpenColorIO config {}: {}", used, e.message);
    return e;
  }
  try {
    std::istringstream in(*text);
    auto config = OCIO::Config::CreateFromStream(in)->createEditableCopy();
    // As CreateFromFile: the config's relative search paths start at its own directory.
    const std::filesystem::path at = files.root && !explicit_path.empty() && std::filesystem::path(used).is_relative()
                                         ? files.root->path() / used
                                         : std::filesystem::absolute(used);
    config->setWorkingDir(at.parent_path().string().c_str());
    return OCIO::ConstConfigRcPtr(config);
  } catch (const std::exception& e) {
    return make_error("grade.ocio", fmt::format("OpenColorIO config {}: {}", used, one_line(e.what())), "ocio_config");
  }
}

// hdrd's working space as a colour space of (a copy of) the config: linear Rec.2020 D65
// -> CIE XYZ -> ACES2065-1 (OCIO's Bradford built-in) -> the aces_interchange space's own
// transform to the config reference.
Result<std::string> add_working_space(OCIO::ConfigRcPtr& cfg) {
  auto aces = cfg->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE);
  if (!aces) return make_error("grade.ocio", "no aces_interchange colour space", "ocio_config");
  auto group = OCIO::GroupTransform::Create();
  group->appendTransform(matrix_transform(color::rgb_to_xyz(color::kRec2020)));
  group->appendTransform(builtin(kAp0ToXyz, true));
  if (auto to_ref = aces->getTransform(OCIO::COLORSPACE_DIR_TO_REFERENCE)) {
    group->appendTransform(to_ref->createEditableCopy());
  } else if (auto from_ref = aces->getTransform(OCIO::COLORSPACE_DIR_FROM_REFERENCE)) {
    auto inv = from_ref->createEditableCopy();
    inv->setDirection(OCIO::TRANSFORM_DIR_INVERSE);
    group->appendTransform(inv);
  }
  auto cs = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_SCENE);
  cs->setName(kWorkingName);
  cs->setEncoding("scene-linear");
  cs->setTransform(group, OCIO::COLORSPACE_DIR_TO_REFERENCE);
  cfg->addColorSpace(cs);
  return std::string(kWorkingName);
}

struct ConfigContext {
  OCIO::ConfigRcPtr cfg;
  std::string path, working;
  nlohmann::json desc;
  // The verified copies OpenColorIO reads instead of a request's files (a confined config's
  // LUTs, a LUT in a named colour space); they must outlast getProcessor().
  std::optional<io::PrivateCopies> copies;
};

// Every FileTransform in `t` (groups searched through).
void file_transforms(const OCIO::ConstTransformRcPtr& t, std::vector<std::string>& out) {
  if (!t) return;
  if (auto g = OCIO::DynamicPtrCast<const OCIO::GroupTransform>(t)) {
    for (int i = 0; i < g->getNumTransforms(); ++i) file_transforms(g->getTransform(i), out);
  } else if (auto f = OCIO::DynamicPtrCast<const OCIO::FileTransform>(t)) {
    if (f->getSrc()) out.emplace_back(f->getSrc());
  }
}

// The sources of every FileTransform anywhere in the config: colour spaces, looks, view
// transforms, named transforms, both directions.
std::vector<std::string> config_file_sources(const OCIO::Config& c) {
  std::vector<std::string> out;
  for (int i = 0; i < c.getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL); ++i) {
    auto cs = c.getColorSpace(c.getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL, i));
    if (!cs) continue;
    file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_TO_REFERENCE), out);
    file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_FROM_REFERENCE), out);
  }
  for (int i = 0; i < c.getNumLooks(); ++i)
    if (auto look = c.getLook(c.getLookNameByIndex(i))) {
      file_transforms(look->getTransform(), out);
      file_transforms(look->getInverseTransform(), out);
    }
  for (int i = 0; i < c.getNumViewTransforms(); ++i)
    if (auto vt = c.getViewTransform(c.getViewTransformNameByIndex(i))) {
      file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_TO_REFERENCE), out);
      file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE), out);
    }
  for (int i = 0; i < c.getNumNamedTransforms(OCIO::NAMEDTRANSFORM_ALL); ++i)
    if (auto nt = c.getNamedTransform(c.getNamedTransformNameByIndex(OCIO::NAMEDTRANSFORM_ALL, i))) {
      file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_FORWARD), out);
      file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_INVERSE), out);
    }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// `p` (absolute, normalised) relative to `root`, or empty when it is not inside it.
std::filesystem::path inside(const std::filesystem::path& p, const std::filesystem::path& root) {
  auto rel = p.lexically_normal().lexically_relative(root);
  if (rel.empty() || *rel.begin() == "..") return {};
  return rel;
}

// A config read from the asset root names its LUTs by paths OpenColorIO would resolve and
// open itself, when it builds a processor: a symbolic link, FIFO or hard link swapped in
// would be followed. Instead each file it can name is resolved now, read through the file
// model (the same refusals as any input) and copied into a private directory laid out as
// the asset root is (under root/); the config's working directory and search paths then point there, so
// OpenColorIO finds only the copies.
Result<void> confine_config(ConfigContext& ctx, const io::InputFiles& files) {
  const auto root = files.root->path();
  const auto config_dir = std::filesystem::path(ctx.cfg->getWorkingDir());
  auto copies = io::PrivateCopies::create();
  if (!copies) return copies.error();
  auto context = ctx.cfg->getCurrentContext();
  for (const auto& src : config_file_sources(*ctx.cfg)) {
    const std::string expanded = context->resolveStringVar(src.c_str());
    if (std::filesystem::path(expanded).is_absolute())
      return make_error("path.forbidden", fmt::format("OpenColorIO config {}: LUT '{}' is an absolute path; a config in {} names "
                                                      "its files relative to its search path", ctx.path, one_line(src),
                                                      files.root->options().what), "ocio_config");
    std::string resolved;
    try {
      resolved = context->resolveFileLocation(src.c_str());
    } catch (const std::exception&) {
      continue;  // not there: OpenColorIO says so if the transform is used
    }
    const auto rel = inside(std::filesystem::absolute(resolved), root);
    if (rel.empty())
      return make_error("path.forbidden", fmt::format("OpenColorIO config {}: LUT '{}' leads outside {}", ctx.path,
                                                      one_line(src), files.root->options().what), "ocio_config");
    auto bytes = files.read(rel, io::kMaxInputFileBytes);
    if (!bytes) {
      Error e = io::reader_error(bytes.error(), "grade.ocio", "grade.ocio", "ocio_config");
      e.message = fmt::format("OpenColorIO config {}: LUT '{}': {}", ctx.path, one_line(src), e.message);
      return e;
    }
    auto copy = copies->add("root" / rel, *bytes);
    if (!copy) return copy.error();
  }
  // The same resolution, in the copy: every search path mapped to its place there (one that
  // leads outside the root to a directory that holds nothing).
  std::vector<std::string> search;
  for (int i = 0; i < ctx.cfg->getNumSearchPaths(); ++i) {
    std::filesystem::path sp = context->resolveStringVar(ctx.cfg->getSearchPath(i));
    if (!sp.is_absolute()) sp = config_dir / sp;
    const auto rel = inside(sp, root);
    search.push_back((rel.empty() ? copies->map("outside") : copies->map("root" / rel)).lexically_normal().string());
  }
  const auto config_rel = inside(config_dir, root);
  ctx.cfg->setWorkingDir(copies->map("root" / config_rel).lexically_normal().c_str());
  ctx.cfg->clearSearchPaths();
  for (const auto& sp : search) ctx.cfg->addSearchPath(sp.c_str());
  ctx.copies.emplace(std::move(*copies));
  return {};
}

Result<std::string> check_colour_space(const OCIO::Config& cfg, const std::string& name) {
  if (cfg.getColorSpace(name.c_str())) return name;
  return make_error("grade.ocio", fmt::format("OpenColorIO config has no colour space '{}' (available: {})", name,
                                              colour_space_names(cfg)), "ocio_colorspace");
}

Result<ConfigContext> config_context(const grade::GradeSettings& s, std::vector<std::string>* warnings) {
  ConfigContext ctx;
  auto base = open_config(s.ocio_config, ctx.path, s.files);
  if (!base) return base.error();
  ctx.cfg = (*base)->createEditableCopy();
  if (!s.ocio_config.empty() && s.files.root) {  // a config the request named, in the asset root
    auto ok = confine_config(ctx, s.files);
    if (!ok) return ok.error();
  }
  const bool names_working = !s.ocio_colorspace.empty() && s.lut_path.empty() &&
                             (!s.ocio_look.empty() || !s.ocio_display.empty());
  if (names_working) {
    auto ok = check_colour_space(*ctx.cfg, s.ocio_colorspace);
    if (!ok) return ok.error();
    ctx.working = *ok;
  } else if (ctx.cfg->hasRole(OCIO::ROLE_INTERCHANGE_SCENE)) {
    auto w = add_working_space(ctx.cfg);
    if (!w) return w.error();
    ctx.working = *w;
  } else if (auto lin = ctx.cfg->getColorSpace(OCIO::ROLE_SCENE_LINEAR)) {
    ctx.working = lin->getName();
    if (warnings)
      warnings->push_back(fmt::format("OpenColorIO config has no aces_interchange role: assuming its scene_linear "
                                      "colour space '{}' is linear Rec.2020 (name another with --ocio-colorspace)",
                                      ctx.working));
  } else {
    return make_error("grade.ocio", "OpenColorIO config has neither an aces_interchange nor a scene_linear role; "
                                    "name the colour space of hdrd's linear Rec.2020 with --ocio-colorspace",
                      "ocio_colorspace");
  }
  ctx.desc = {{"source", "ocio-config"}, {"config", ctx.path}, {"working_colorspace", ctx.working}};
  return ctx;
}

// Display-referred output decoded to Rec.2020 display nits: display colour space ->
// cie_xyz_d65_interchange -> Rec.2020, where XYZ Y = 1 is 100 cd/m2 for "hdr-video"
// encodings (OCIO's ST 2084 built-ins use nits/100) and the display peak otherwise (SDR).
Result<void> append_decode(ConfigContext& ctx, OCIO::GroupTransformRcPtr& group, const std::string& display_cs,
                           double target_peak_nits) {
  auto cs = ctx.cfg->getColorSpace(display_cs.c_str());
  if (!cs || cs->getReferenceSpaceType() != OCIO::REFERENCE_SPACE_DISPLAY)
    return make_error("grade.ocio", fmt::format("'{}' is not a display colour space of the config; hdrd decodes "
                                                "display/view output to nits only through OCIO 2 display colour spaces",
                                                display_cs), "ocio_display");
  auto xyz = ctx.cfg->getColorSpace(OCIO::ROLE_INTERCHANGE_DISPLAY);
  if (!xyz)
    return make_error("grade.ocio", "OpenColorIO config has no cie_xyz_d65_interchange role: cannot decode display "
                                    "output to nits", "ocio_config");
  const std::string encoding = cs->getEncoding();
  const double unit_nits = encoding == "hdr-video" ? 100.0 : target_peak_nits;
  auto back = OCIO::ColorSpaceTransform::Create();
  back->setSrc(display_cs.c_str());
  back->setDst(xyz->getName());
  group->appendTransform(back);
  group->appendTransform(matrix_transform(color::xyz_to_rgb(color::kRec2020), unit_nits));
  ctx.desc["display_colorspace"] = display_cs;
  ctx.desc["encoding"] = encoding;
  ctx.desc["xyz_unit_nits"] = unit_nits;
  return {};
}

Result<void> check_look(const OCIO::Config& cfg, const std::string& looks) {
  if (looks.find_first_of(",:+-") != std::string::npos || cfg.getLook(looks.c_str())) return {};
  return make_error("grade.ocio", fmt::format("OpenColorIO config has no look '{}' (available: {})", looks,
                                              join_names(cfg.getNumLooks(), [&](int i) { return cfg.getLookNameByIndex(i); })),
                    "ocio_look");
}

Result<std::string> check_display_view(const OCIO::Config& cfg, const grade::GradeSettings& s) {
  const auto displays = join_names(cfg.getNumDisplays(), [&](int i) { return cfg.getDisplay(i); });
  bool found = false;
  for (int i = 0; i < cfg.getNumDisplays(); ++i) found |= s.ocio_display == cfg.getDisplay(i);
  if (!found)
    return make_error("grade.ocio", fmt::format("OpenColorIO config has no display '{}' (available: {})", s.ocio_display,
                                                displays), "ocio_display");
  const char* d = s.ocio_display.c_str();
  const std::string view = s.ocio_view.empty() ? cfg.getDefaultView(d) : s.ocio_view;
  const auto views = join_names(cfg.getNumViews(d), [&](int i) { return cfg.getView(d, i); });
  bool has_view = false;
  for (int i = 0; i < cfg.getNumViews(d); ++i) has_view |= view == cfg.getView(d, i);
  if (!has_view)
    return make_error("grade.ocio", fmt::format("OpenColorIO display '{}' has no view '{}' (available: {})", s.ocio_display,
                                                view, views), "ocio_view");
  return view;
}

Result<ConfigGrade> build_config_grade(ConfigContext& ctx, const grade::GradeSettings& s, double target_peak_nits) {
  auto group = OCIO::GroupTransform::Create();
  ConfigGrade g;
  if (!s.lut_path.empty()) {  // a LUT in a named colour space
    auto cs = check_colour_space(*ctx.cfg, s.ocio_colorspace);
    if (!cs) return cs.error();
    // Read through the file model now; OpenColorIO reads a private copy of these bytes.
    auto bytes = read_lut(s.files, s.lut_path);
    if (!bytes) return bytes.error();
    if (!ctx.copies) {
      auto copies = io::PrivateCopies::create();
      if (!copies) return copies.error();
      ctx.copies.emplace(std::move(*copies));
    }
    auto copy = ctx.copies->add(std::filesystem::path("lut") / copy_name(s.lut_path), *bytes);
    if (!copy) return copy.error();
    auto to = OCIO::ColorSpaceTransform::Create();
    to->setSrc(ctx.working.c_str());
    to->setDst(cs->c_str());
    auto ft = OCIO::FileTransform::Create();
    ft->setSrc(copy->c_str());
    ft->setInterpolation(s.trilinear ? OCIO::INTERP_LINEAR : OCIO::INTERP_TETRAHEDRAL);
    auto from = OCIO::ColorSpaceTransform::Create();
    from->setSrc(cs->c_str());
    from->setDst(ctx.working.c_str());
    group->appendTransform(to);
    group->appendTransform(ft);
    group->appendTransform(from);
    ctx.desc["lut"] = s.lut_path;
    ctx.desc["lut_colorspace"] = *cs;
  } else if (!s.ocio_display.empty()) {
    auto view = check_display_view(*ctx.cfg, s);
    if (!view) return view.error();
    auto dv = OCIO::DisplayViewTransform::Create();
    dv->setSrc(ctx.working.c_str());
    dv->setDisplay(s.ocio_display.c_str());
    dv->setView(view->c_str());
    group->appendTransform(dv);
    std::string dcs = ctx.cfg->getDisplayViewColorSpaceName(s.ocio_display.c_str(), view->c_str());
    if (dcs == "<USE_DISPLAY_NAME>") dcs = s.ocio_display;
    auto ok = append_decode(ctx, group, dcs, target_peak_nits);
    if (!ok) return ok.error();
    g.placement = grade::Placement::baked;
    ctx.desc["display"] = s.ocio_display;
    ctx.desc["view"] = *view;
  } else if (!s.ocio_look.empty()) {
    auto ok = check_look(*ctx.cfg, s.ocio_look);
    if (!ok) return ok.error();
    auto lt = OCIO::LookTransform::Create();
    lt->setSrc(ctx.working.c_str());
    lt->setDst(ctx.working.c_str());
    lt->setLooks(s.ocio_look.c_str());
    group->appendTransform(lt);
    ctx.desc["look"] = s.ocio_look;
  } else {  // a display colour space alone
    auto cs = check_colour_space(*ctx.cfg, s.ocio_colorspace);
    if (!cs) return cs.error();
    if (ctx.cfg->getColorSpace(cs->c_str())->getReferenceSpaceType() != OCIO::REFERENCE_SPACE_DISPLAY)
      return make_error("grade.ocio", fmt::format("--ocio-colorspace '{}' alone needs a display colour space; for a "
                                                  "scene-referred one pass --lut (the LUT's input space) or --ocio-look",
                                                  *cs), "ocio_colorspace");
    auto to = OCIO::ColorSpaceTransform::Create();
    to->setSrc(ctx.working.c_str());
    to->setDst(cs->c_str());
    group->appendTransform(to);
    auto ok = append_decode(ctx, group, *cs, target_peak_nits);
    if (!ok) return ok.error();
    g.placement = grade::Placement::baked;
  }
  g.processor = make_processor(ctx.cfg->getProcessor(group));
  ctx.desc["placement"] = std::string(grade::to_string(g.placement));
  g.description = ctx.desc;
  return g;
}

}  // namespace

Result<ConfigGrade> load_config_grade(const grade::GradeSettings& s, double target_peak_nits,
                                      std::vector<std::string>* warnings) {
  quiet_logging();
  try {
    OCIO::ClearAllCaches();
    auto ctx = config_context(s, warnings);
    if (!ctx) return ctx.error();
    return build_config_grade(*ctx, s, target_peak_nits);
  } catch (const std::exception& e) {
    return make_error("grade.ocio", fmt::format("OpenColorIO: {}", one_line(e.what())), "ocio_config");
  }
}

// ---- ACES output transforms as tone curves -----------------------------------------------
const std::vector<AcesOutput>& aces_outputs() {
  static const std::vector<AcesOutput> v = {
      {"aces-ocio-sdr-video", "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - SDR-VIDEO_1.0", 100, 100, &color::kRec709},
      {"aces-ocio-hdr-1000", "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - HDR-VIDEO-1000nit-15nit-REC2020lim_1.1", 1000, 100,
       &color::kRec2020},
      {"aces-ocio-hdr-2000", "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - HDR-VIDEO-2000nit-15nit-REC2020lim_1.1", 2000, 100,
       &color::kRec2020},
      {"aces-ocio-hdr-4000", "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - HDR-VIDEO-4000nit-15nit-REC2020lim_1.1", 4000, 100,
       &color::kRec2020},
  };
  return v;
}

namespace {

using color::Vec3;

// relative Rec.2020 -> XYZ -> ACES2065-1 (Bradford) -> ACES output -> display XYZ (D65).
OCIO::ConstCPUProcessorRcPtr aces_processor(std::size_t index) {
  static std::mutex mu;
  static std::vector<OCIO::ConstCPUProcessorRcPtr> cache(aces_outputs().size());
  std::lock_guard lock(mu);
  if (!cache[index]) {
    quiet_logging();
    auto group = OCIO::GroupTransform::Create();
    group->appendTransform(matrix_transform(color::rgb_to_xyz(color::kRec2020)));
    group->appendTransform(builtin(kAp0ToXyz, true));
    group->appendTransform(builtin(aces_outputs()[index].builtin));
    cache[index] = OCIO::Config::CreateRaw()->getProcessor(group)->getDefaultCPUProcessor();
  }
  return cache[index];
}

class AcesCurve final : public tonemap::Curve {
 public:
  AcesCurve(std::size_t index, const tonemap::Display& d)
      : cpu_(aces_processor(index)),
        to_display_(color::xyz_to_rgb(*aces_outputs()[index].display_primaries)),
        display_to_rec2020_(color::rgb_to_rgb(*aces_outputs()[index].display_primaries, color::kRec2020)),
        scale_(aces_outputs()[index].unit_nits / d.paper_white_nits),
        transform_max_(aces_outputs()[index].peak_nits / aces_outputs()[index].unit_nits),
        max_y_(d.max_y()) {}
  double map(double x) const override { return map_rgb({x, x, x}, tonemap::Apply::rgb).y; }
  // Fixed-peak transform: the output transform's own clip to its peak in its display
  // primaries, then, on a display dimmer than that peak, the excess clipped per channel
  // (the registry's rule: no curve exceeds the display peak).
  Vec3 map_rgb(Vec3 rgb, tonemap::Apply) const override {
    float px[3] = {float(std::max(rgb.x, 0.0)), float(std::max(rgb.y, 0.0)), float(std::max(rgb.z, 0.0))};
    cpu_->applyRGB(px);
    const Vec3 d = to_display_ * Vec3{px[0], px[1], px[2]};
    const auto odt_clip = [&](double v) { return std::clamp(v, 0.0, transform_max_); };
    const Vec3 out = display_to_rec2020_ * Vec3{odt_clip(d.x), odt_clip(d.y), odt_clip(d.z)} * scale_;
    const auto clip = [&](double v) { return std::clamp(v, 0.0, max_y_); };
    return {clip(out.x), clip(out.y), clip(out.z)};
  }

 private:
  OCIO::ConstCPUProcessorRcPtr cpu_;
  color::Mat3 to_display_, display_to_rec2020_;
  double scale_, transform_max_, max_y_;
};

template <std::size_t I>
std::unique_ptr<tonemap::Curve> prepare_aces(const tonemap::Display& d, const tonemap::ParamValues&) {
  return std::make_unique<AcesCurve>(I, d);
}

constexpr std::array<std::string_view, 4> kAcesDescriptions = {
    "ACES 1.0 SDR video output transform (RRT + ODT, 100 nits) via OpenColorIO; fixed peak 100 cd/m2",
    "ACES 1.1 HDR video output transform, 1000 nits, 15 nits mid grey, Rec.2020-limited, via OpenColorIO; "
    "fixed peak 1000 cd/m2",
    "ACES 1.1 HDR video output transform, 2000 nits, 15 nits mid grey, Rec.2020-limited, via OpenColorIO; "
    "fixed peak 2000 cd/m2",
    "ACES 1.1 HDR video output transform, 4000 nits, 15 nits mid grey, Rec.2020-limited, via OpenColorIO; "
    "fixed peak 4000 cd/m2",
};

}  // namespace

void register_tone_curves() {
  using P = std::unique_ptr<tonemap::Curve> (*)(const tonemap::Display&, const tonemap::ParamValues&);
  static constexpr std::array<P, 4> kPrepare = {&prepare_aces<0>, &prepare_aces<1>, &prepare_aces<2>, &prepare_aces<3>};
  static_assert(kPrepare.size() == kAcesDescriptions.size());
  for (std::size_t i = 0; i < kPrepare.size(); ++i) {
    tonemap::ToneCurveInfo info{aces_outputs()[i].curve_name,
                                kAcesDescriptions[i],
                                "Academy ACES 1.0/1.1 RRT+ODT as built into OpenColorIO 2.1 (BuiltinTransform)",
                                {},
                                tonemap::Apply::rgb,
                                false,
                                false,
                                false,
                                kPrepare[i]};
    tonemap::register_curve(std::move(info));
  }
}

namespace {
[[maybe_unused]] const bool kRegistered = (register_tone_curves(), true);
}

}  // namespace hdrd::ocio

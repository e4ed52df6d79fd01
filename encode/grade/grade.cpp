// Grades behind encode/grade/grade.hpp (RTR4 §8.2.3): a LUT placed before the tone curve
// (scene: relative values through a declared shaper), after it (display: PQ of display
// nits, so one look serves every peak), or holding the tone curve itself (baked: scene
// values in, PQ of display nits out, tied to the peak it was baked for).
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>
#include <tuple>

#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/grade/ocio.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::grade {

std::string_view to_string(Placement p) {
  switch (p) {
    case Placement::scene: return "scene";
    case Placement::display: return "display";
    case Placement::baked: return "baked";
  }
  return "?";
}

std::optional<Placement> parse_placement(std::string_view s) {
  for (Placement p : {Placement::scene, Placement::display, Placement::baked})
    if (to_string(p) == s) return p;
  return std::nullopt;
}

std::string_view to_string(Shaper s) {
  switch (s) {
    case Shaper::pq: return "pq";
    case Shaper::log2: return "log2";
    case Shaper::sqrt: return "sqrt";
    case Shaper::sqrt_sqrt: return "sqrt-sqrt";
    case Shaper::none: return "none";
  }
  return "?";
}

std::optional<Shaper> parse_shaper(std::string_view s) {
  for (Shaper k : {Shaper::pq, Shaper::log2, Shaper::sqrt, Shaper::sqrt_sqrt, Shaper::none})
    if (to_string(k) == s) return k;
  return std::nullopt;
}

namespace {

using lut::ShaperSpec;
using lut::ShaperTable;

// Display placement and every LUT output in display nits: PQ of absolute luminance.
const ShaperSpec kDisplayPq{Shaper::pq, 0.0, transfer::kPqPeakNits};
constexpr std::size_t kChunkPixels = 1024;  // shaper + LUT + unshaper per L1-sized block

// Shaped input -> table -> decoded output, in blocks, in the calling thread (the encode
// pipeline already runs rows on its own threads).
class ShapedGrade : public Grade {
 public:
  ShapedGrade(Placement p, ShaperSpec in, ShaperSpec out) : placement_(p), in_(in), out_(out) {}
  Placement placement() const override { return placement_; }
  void apply(float* rgba, std::size_t pixels) const override {
    for (std::size_t i = 0; i < pixels; i += kChunkPixels) {
      const std::size_t n = std::min(kChunkPixels, pixels - i);
      float* block = rgba + 4 * i;
      in_.forward_rgba(block, n);
      apply_table(block, n);
      out_.inverse_rgba(block, n);
    }
  }
  std::optional<GpuLut> gpu_lut() const override { return resampled(65); }

 protected:
  virtual void apply_table(float* rgba, std::size_t pixels) const = 0;
  // The table in shaped units sampled on a size^3 lattice (exact where the table is one).
  GpuLut resampled(int size) const {
    GpuLut g;
    g.size = size;
    const auto id = lut::Lut3D::identity(size);
    std::vector<float> rgba(id.rgb.size() / 3 * 4, 1.0f);
    for (std::size_t e = 0; e < id.rgb.size() / 3; ++e)
      for (int c = 0; c < 3; ++c) rgba[e * 4 + c] = id.rgb[e * 3 + c];
    apply_table(rgba.data(), rgba.size() / 4);
    g.rgb.resize(id.rgb.size());
    for (std::size_t e = 0; e < id.rgb.size() / 3; ++e)
      for (int c = 0; c < 3; ++c) g.rgb[e * 3 + c] = rgba[e * 4 + c];
    fill_shaper(g);
    return g;
  }
  void fill_shaper(GpuLut& g) const {
    g.shaper = in_.spec().kind;
    g.shaper_min = in_.spec().min;
    g.shaper_max = in_.spec().max;
  }
  nlohmann::json base_description() const {
    return {{"placement", std::string(to_string(placement_))},
            {"shaper", placement_ == Placement::display ? std::string("pq-nits") : lut::to_string(in_.spec())},
            {"output", placement_ == Placement::scene ? lut::to_string(out_.spec()) : std::string("pq-nits")}};
  }
  Placement placement_;
  ShaperTable in_, out_;
};

// A .cube through hdrd's own interpolation (SIMD fast path for the 3D table).
class CubeGrade final : public ShapedGrade {
 public:
  CubeGrade(Placement p, ShaperSpec in, ShaperSpec out, lut::CubeFile cube, lut::Interpolation interp,
            std::string path, std::optional<double> baked_peak)
      : ShapedGrade(p, in, out), cube_(std::move(cube)), interp_(interp), path_(std::move(path)), baked_peak_(baked_peak) {
    if (cube_.lut3d) fast_.emplace(*cube_.lut3d, interp_);
  }
  std::optional<double> baked_peak_nits() const override { return baked_peak_; }
  nlohmann::json describe() const override {
    auto j = base_description();
    j["source"] = "cube";
    j["file"] = path_;
    if (!cube_.title.empty()) j["title"] = cube_.title;
    if (cube_.lut3d) j["size"] = cube_.lut3d->size;
    if (cube_.lut1d) j["size_1d"] = cube_.lut1d->size;
    j["interpolation"] = std::string(lut::to_string(interp_));
    if (baked_peak_) j["baked_peak_nits"] = *baked_peak_;
    return j;
  }
  std::optional<GpuLut> gpu_lut() const override {
    const bool exact = cube_.lut3d && !cube_.lut1d && cube_.lut3d->domain.is_unit();
    if (!exact) return resampled(65);
    GpuLut g;
    g.size = cube_.lut3d->size;
    g.rgb = cube_.lut3d->rgb;
    g.trilinear = interp_ == lut::Interpolation::trilinear;
    fill_shaper(g);
    return g;
  }

 private:
  void apply_table(float* rgba, std::size_t pixels) const override {
    if (cube_.lut1d)
      for (std::size_t i = 0; i < pixels; ++i) {
        const auto v = lut::eval(*cube_.lut1d, {rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]});
        std::copy(v.begin(), v.end(), rgba + 4 * i);
      }
    if (fast_) fast_->apply(rgba, pixels, 1);
  }
  lut::CubeFile cube_;
  lut::Interpolation interp_;
  std::optional<lut::Applier3D> fast_;
  std::string path_;
  std::optional<double> baked_peak_;
};

// Any other format, applied by OpenColorIO's CPU processor between the same shapers.
class OcioFileGrade final : public ShapedGrade {
 public:
  OcioFileGrade(Placement p, ShaperSpec in, ShaperSpec out, ocio::Processor proc, lut::Interpolation interp,
                std::string path)
      : ShapedGrade(p, in, out), proc_(std::move(proc)), interp_(interp), path_(std::move(path)) {}
  nlohmann::json describe() const override {
    auto j = base_description();
    j["source"] = "ocio-file";
    j["file"] = path_;
    j["interpolation"] = std::string(lut::to_string(interp_));
    j["ocio_version"] = ocio::version();
    return j;
  }

 private:
  void apply_table(float* rgba, std::size_t pixels) const override { proc_.apply_rgba(rgba, pixels, 1); }
  ocio::Processor proc_;
  lut::Interpolation interp_;
  std::string path_;
};

// An OpenColorIO config transform on working values (no shaper: OCIO shapes itself).
class OcioConfigGrade final : public Grade {
 public:
  explicit OcioConfigGrade(ocio::ConfigGrade g) : g_(std::move(g)) {}
  Placement placement() const override { return g_.placement; }
  void apply(float* rgba, std::size_t pixels) const override { g_.processor.apply_rgba(rgba, pixels, 1); }
  nlohmann::json describe() const override { return g_.description; }
  // Sampled on a 65^3 PQ-shaped lattice for the GPU pass (an approximation of OCIO's ops).
  std::optional<GpuLut> gpu_lut() const override {
    const ShaperTable in(ShaperSpec::defaults(Shaper::pq));
    const ShaperTable out(g_.placement == Placement::scene ? in.spec() : kDisplayPq);
    GpuLut g;
    g.size = 65;
    const auto id = lut::Lut3D::identity(g.size);
    std::vector<float> rgba(id.rgb.size() / 3 * 4, 1.0f);
    for (std::size_t e = 0; e < id.rgb.size() / 3; ++e)
      for (int c = 0; c < 3; ++c) rgba[e * 4 + c] = in.inverse(id.rgb[e * 3 + c]);
    apply(rgba.data(), rgba.size() / 4);
    out.forward_rgba(rgba.data(), rgba.size() / 4);
    g.rgb.resize(id.rgb.size());
    for (std::size_t e = 0; e < id.rgb.size() / 3; ++e)
      for (int c = 0; c < 3; ++c) g.rgb[e * 3 + c] = rgba[e * 4 + c];
    g.shaper = Shaper::pq;
    g.shaper_max = in.spec().max;
    return g;
  }

 private:
  ocio::ConfigGrade g_;
};

bool is_cube(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".cube";
}

void warn(std::vector<std::string>* w, std::string text) {
  if (w) w->push_back(std::move(text));
}

// The shaper of a scene/baked LUT: the one asked for, else the one the file records, else PQ.
ShaperSpec choose_shaper(const GradeSettings& s, const std::optional<ShaperSpec>& recorded,
                         std::vector<std::string>* warnings) {
  if (s.shaper) {
    if (recorded && recorded->kind != *s.shaper)
      warn(warnings, fmt::format("{}: the file records shaper {}, using {} as asked", s.lut_path,
                                 lut::to_string(*recorded), to_string(*s.shaper)));
    ShaperSpec spec = recorded && recorded->kind == *s.shaper ? *recorded : ShaperSpec::defaults(*s.shaper);
    if (s.shaper_range) std::tie(spec.min, spec.max) = *s.shaper_range;
    return spec;
  }
  return recorded ? *recorded : ShaperSpec::defaults(Shaper::pq);
}

void check_display_shaper(const GradeSettings& s, const std::optional<ShaperSpec>& recorded,
                          std::vector<std::string>* warnings) {
  if (s.shaper)
    warn(warnings, fmt::format("--lut-shaper {} is ignored for display placement: the LUT input there is "
                               "PQ-encoded display luminance", to_string(*s.shaper)));
  else if (recorded && recorded->kind != Shaper::pq)
    warn(warnings, fmt::format("{}: made for shaper {}, but display placement feeds it PQ of display nits",
                               s.lut_path, lut::to_string(*recorded)));
}

std::optional<double> check_baked_peak(const GradeSettings& s, const std::optional<lut::BakeRecord>& baked,
                                       double target_peak_nits, std::vector<std::string>* warnings) {
  if (s.placement != Placement::baked) {
    if (baked)
      warn(warnings, fmt::format("{}: has a tone curve baked in for {} cd/m2; use --grade baked", s.lut_path,
                                 baked->peak_nits));
    return std::nullopt;
  }
  if (!baked) {
    warn(warnings, fmt::format("{}: does not record the peak it was baked for; its output is taken as PQ-encoded "
                               "display nits", s.lut_path));
    return std::nullopt;
  }
  if (std::fabs(baked->peak_nits - target_peak_nits) > 0.5)
    warn(warnings, fmt::format("{}: baked for a {} cd/m2 peak, but the display peak is {} cd/m2: re-bake it "
                               "(hdrd lut bake --peak {})", s.lut_path, baked->peak_nits, target_peak_nits,
                               target_peak_nits));
  return baked->peak_nits;
}

Result<std::shared_ptr<const Grade>> load_lut_file(const GradeSettings& s, double target_peak_nits,
                                                   std::vector<std::string>* warnings) {
  const std::filesystem::path path(s.lut_path);
  // Opened through the file model: a link, a FIFO, a hard link or a path outside the root is
  // refused here; a .cube is then parsed from this descriptor's bytes.
  auto fd = s.files.open(path);
  if (!fd) {
    Error e = io::reader_error(fd.error(), "grade.file", "grade.file", "lut");
    if (e.code == "grade.file") e.message = fmt::format("{}: no such LUT file ({})", s.lut_path, fd.error().message);
    return e;
  }
  const auto interp = s.trilinear ? lut::Interpolation::trilinear : lut::Interpolation::tetrahedral;
  lut::CubeFile cube;
  if (is_cube(path)) {
    auto text = io::read_all(fd->get(), s.lut_path, std::size_t(1) << 30);
    if (!text) return io::reader_error(text.error(), "cube.io", "cube.io", "lut");
    auto parsed = lut::parse_cube(*text, s.lut_path);
    if (!parsed) return parsed.error();
    cube = std::move(*parsed);
  }
  const auto recorded = lut::shaper_from_comments(cube.comments);
  const auto baked = lut::bake_record_from_comments(cube.comments);
  const auto baked_peak = check_baked_peak(s, baked, target_peak_nits, warnings);
  ShaperSpec in = kDisplayPq, out = kDisplayPq;
  if (s.placement == Placement::display) {
    check_display_shaper(s, recorded, warnings);
  } else {
    in = choose_shaper(s, recorded, warnings);
    if (s.placement == Placement::scene) out = in;
  }
  if (is_cube(path))
    return std::shared_ptr<const Grade>(
        std::make_shared<CubeGrade>(s.placement, in, out, std::move(cube), interp, s.lut_path, baked_peak));
  auto bytes = io::read_all(fd->get(), s.lut_path, io::kMaxInputFileBytes);
  if (!bytes) return io::reader_error(bytes.error(), "grade.file", "grade.file", "lut");
  auto proc = ocio::file_transform(*bytes, path, interp);
  if (!proc) return proc.error();
  return std::shared_ptr<const Grade>(std::make_shared<OcioFileGrade>(s.placement, in, out, *proc, interp, s.lut_path));
}

}  // namespace

Result<std::shared_ptr<const Grade>> load_grade(const GradeSettings& settings, double target_peak_nits,
                                                std::vector<std::string>* warnings) {
  if (settings.empty()) return make_error("grade.empty", "no grade asked for (no --lut and no --ocio-* choice)", "lut");
  if (!(target_peak_nits > 0) || !std::isfinite(target_peak_nits))
    return make_error("grade.peak", fmt::format("target peak {} cd/m2 is not a positive luminance", target_peak_nits),
                      "display.peak_nits");
  const bool config = !settings.ocio_look.empty() || !settings.ocio_display.empty() ||
                      !settings.ocio_colorspace.empty();
  if (!config) return load_lut_file(settings, target_peak_nits, warnings);
  auto g = ocio::load_config_grade(settings, target_peak_nits, warnings);
  if (!g) return g.error();
  if (g->placement != settings.placement && settings.placement != Placement::display)
    warn(warnings, fmt::format("--grade {} is ignored: this OpenColorIO transform applies at {} placement",
                               to_string(settings.placement), to_string(g->placement)));
  return std::shared_ptr<const Grade>(std::make_shared<OcioConfigGrade>(std::move(*g)));
}

}  // namespace hdrd::grade

// ---- Baking ------------------------------------------------------------------------------
namespace hdrd::lut {

namespace {
constexpr const char* kBakedTag = "HDRD_BAKED ";

double pq_of(double nits) { return transfer::pq_inverse_eotf(nits); }

// Deterministic samples (a fixed LCG): the same error report on every run and machine.
struct Lcg {
  std::uint64_t s = 0x9E3779B97F4A7C15ull;
  double next() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) * 0x1.0p-53;
  }
};
}  // namespace

std::string bake_comment(const BakeRecord& r) {
  return fmt::format("{}peak_nits={} paper_white_nits={} curve={} apply={}", kBakedTag, r.peak_nits,
                     r.paper_white_nits, r.curve, r.apply);
}

std::optional<BakeRecord> bake_record_from_comments(const std::vector<std::string>& comments) {
  for (const auto& c : comments) {
    if (c.rfind(kBakedTag, 0) != 0) continue;
    BakeRecord r;
    std::istringstream in(c.substr(std::string_view(kBakedTag).size()));
    std::string kv;
    while (in >> kv) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) continue;
      const std::string k = kv.substr(0, eq), v = kv.substr(eq + 1);
      if (k == "peak_nits") r.peak_nits = std::strtod(v.c_str(), nullptr);
      if (k == "paper_white_nits") r.paper_white_nits = std::strtod(v.c_str(), nullptr);
      if (k == "curve") r.curve = v;
      if (k == "apply") r.apply = v;
    }
    if (r.peak_nits > 0 && std::isfinite(r.peak_nits)) return r;
  }
  return std::nullopt;
}

BakeError measure_bake_error(const grade::Grade& baked, const ShaperSpec& shaper, int samples,
                             const std::function<std::array<double, 3>(std::array<double, 3>)>& reference_nits) {
  BakeError e;
  Lcg rng;
  double sum = 0;
  const int greys = 1024;
  for (int i = 0; i < samples + greys; ++i) {
    std::array<double, 3> s;
    if (i < samples) s = {rng.next(), rng.next(), rng.next()};
    else s.fill(double(i - samples) / (greys - 1));
    const std::array<double, 3> x = {unshape(shaper, s[0]), unshape(shaper, s[1]), unshape(shaper, s[2])};
    float px[4] = {float(x[0]), float(x[1]), float(x[2]), 1.0f};
    baked.apply(px, 1);
    const auto ref = reference_nits(x);
    double worst = 0;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(pq_of(px[c]) - pq_of(ref[c])));
    sum += worst;
    if (worst > e.max_pq) {
      e.max_pq = worst;
      e.worst_input = x;
    }
  }
  e.samples = samples + greys;
  e.mean_pq = sum / e.samples;
  e.max_code10 = e.max_pq * 1023.0;
  return e;
}

Result<BakeResult> bake_tone_curve(const BakeRequest& rq) {
  if (rq.size < kMin3DSize || rq.size > kMax3DSize)
    return make_error("cube.size", fmt::format("bake size {} is outside {}..{}", rq.size, kMin3DSize, kMax3DSize), "size");
  if (rq.look && rq.look->placement() == grade::Placement::baked)
    return make_error("grade.bake", "a baked LUT cannot be baked again", "lut");
  auto curve = tonemap::prepare(rq.curve, rq.display, rq.params);
  if (!curve) return curve.error();
  const auto* info = tonemap::find_curve(rq.curve);
  const tonemap::Apply apply = rq.apply.value_or(info->default_apply);
  const double pw = rq.display.paper_white_nits;
  const auto& look = rq.look;
  // The analytic pipeline the LUT stands for: relative scene RGB -> display nits.
  const auto analytic = [&](std::array<double, 3> x) {
    if (look && look->placement() == grade::Placement::scene) {
      float px[4] = {float(x[0]), float(x[1]), float(x[2]), 1.0f};
      look->apply(px, 1);
      x = {px[0], px[1], px[2]};
    }
    const color::Vec3 w{std::max(x[0], 0.0), std::max(x[1], 0.0), std::max(x[2], 0.0)};
    color::Vec3 n = (*curve)->map_rgb(w, apply) * pw;
    if (look && look->placement() == grade::Placement::display) {
      float px[4] = {float(n.x), float(n.y), float(n.z), 1.0f};
      look->apply(px, 1);
      n = {px[0], px[1], px[2]};
    }
    return std::array<double, 3>{n.x, n.y, n.z};
  };
  BakeResult out;
  Lut3D t = Lut3D::identity(rq.size);
  for (std::size_t e = 0; e < t.rgb.size(); e += 3) {
    const std::array<double, 3> x = {unshape(rq.shaper, t.rgb[e]), unshape(rq.shaper, t.rgb[e + 1]),
                                     unshape(rq.shaper, t.rgb[e + 2])};
    const auto n = analytic(x);
    for (int c = 0; c < 3; ++c) t.rgb[e + c] = static_cast<float>(pq_of(n[c]));
  }
  out.cube.title = rq.title;
  out.cube.comments = {"Baked by hdrd: relative scene Rec.2020 -> shaper -> tone curve -> PQ of display nits",
                       shaper_comment(rq.shaper),
                       bake_comment({rq.display.peak_nits, pw, rq.curve, std::string(tonemap::to_string(apply))})};
  out.cube.lut3d = std::move(t);
  grade::CubeGrade baked(grade::Placement::baked, rq.shaper, grade::kDisplayPq, out.cube,
                         Interpolation::tetrahedral, "bake", rq.display.peak_nits);
  out.error = measure_bake_error(baked, rq.shaper, rq.error_samples, analytic);
  return out;
}

}  // namespace hdrd::lut

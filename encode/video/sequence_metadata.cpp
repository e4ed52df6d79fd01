#include "encode/video/sequence_metadata.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include <fmt/format.h>

#include "encode/colour/transfer.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/tone/tonemap.hpp"

namespace hdrd::video {

std::string_view to_string(MetadataGranularity g) { return g == MetadataGranularity::scene ? "scene" : "frame"; }

std::optional<MetadataGranularity> parse_granularity(std::string_view s) {
  if (s == "scene") return MetadataGranularity::scene;
  if (s == "frame") return MetadataGranularity::frame;
  return std::nullopt;
}

Result<void> validate(const SequenceMetadataSettings& s) {
  if (s.hdr10plus_target_nits && !(*s.hdr10plus_target_nits >= 100 && *s.hdr10plus_target_nits <= 10000))
    return make_error("video.metadata",
                      fmt::format("HDR10+ target display peak {} cd/m2 is not within [100, 10000]", *s.hdr10plus_target_nits),
                      "video.hdr10plus_target_nits");
  return {};
}

// ---- summaries ---------------------------------------------------------------------------

namespace {

constexpr int kLevels = FrameLight::kPqBins;
double level_signal(int bin) { return static_cast<double>(bin) / (kLevels - 1); }

// Running totals over frames: the maxima, the sum of frame means, the pooled histogram.
struct Totals {
  std::array<double, 3> max_channel{};
  double max_nits = 0, min_nits = INFINITY, mean_sum = 0;
  std::uint64_t frames = 0, pixels = 0;
  std::array<std::uint64_t, kLevels> counts{};

  void add(const FrameLight& f) {
    for (std::size_t c = 0; c < 3; ++c) max_channel[c] = std::max(max_channel[c], f.max_channel_nits[c]);
    max_nits = std::max(max_nits, f.max_nits);
    min_nits = std::min(min_nits, f.min_nits);
    mean_sum += f.mean_nits;
    ++frames;
    pixels += f.pixels;
    for (int i = 0; i < kLevels; ++i) counts[static_cast<std::size_t>(i)] += f.pq_counts[static_cast<std::size_t>(i)];
  }

  LightSummary summary() const {
    LightSummary s;
    if (frames == 0 || pixels == 0) return s;
    s.max_channel_nits = max_channel;
    s.max_nits = max_nits, s.min_nits = min_nits;
    s.mean_nits = mean_sum / static_cast<double>(frames);  // frames of one size: the pooled mean
    // Percentile p: the level of the ceil(p n / 100)-th smallest pixel.
    std::size_t next = 0;
    std::uint64_t below = 0;
    double pq_sum = 0;
    int lowest = -1, highest = 0;
    for (int i = 0; i < kLevels; ++i) {
      const std::uint64_t n = counts[static_cast<std::size_t>(i)];
      if (n == 0) continue;
      if (lowest < 0) lowest = i;
      highest = i;
      pq_sum += level_signal(i) * static_cast<double>(n);
      below += n;
      while (next < kHdr10PlusPercentages.size() &&
             static_cast<double>(below) >= std::ceil(kHdr10PlusPercentages[next] / 100.0 * static_cast<double>(pixels))) {
        s.percentile_nits[next++] = transfer::pq_eotf(level_signal(i));
      }
    }
    s.min_pq = level_signal(std::max(lowest, 0));
    s.max_pq = level_signal(highest);
    s.mean_pq = pq_sum / static_cast<double>(pixels);
    return s;
  }
};

std::uint32_t linear_units(double nits) { return io::to_units(nits, kHdr10PlusUnitNits, 100000, false); }

}  // namespace

struct SequenceMetadata::Pool {
  Totals scene;
};

LightSummary summarise(std::span<const FrameLight* const> frames) {
  Totals t;
  for (const FrameLight* f : frames) t.add(*f);
  return t.summary();
}

Hdr10PlusFrame hdr10plus_from(const LightSummary& light) {
  Hdr10PlusFrame m;
  for (std::size_t c = 0; c < 3; ++c) m.maxscl[c] = linear_units(light.max_channel_nits[c]);
  m.average_maxrgb = linear_units(light.mean_nits);
  for (std::size_t i = 0; i < kHdr10PlusPercentages.size(); ++i)
    m.distribution.push_back({static_cast<std::uint8_t>(kHdr10PlusPercentages[i]), linear_units(light.percentile_nits[i])});
  return m;
}

DoviL1 dovi_l1_from(const LightSummary& light) {
  auto code = [](double e) { return static_cast<std::uint16_t>(std::clamp(std::lround(e * 4095.0), 0L, 4095L)); };
  DoviL1 l{code(light.min_pq), code(light.mean_pq), code(light.max_pq)};
  l.avg_pq = std::clamp(l.avg_pq, l.min_pq, l.max_pq);
  return l;
}

// ---- Bezier curve (HDR10+ profile B) ------------------------------------------------------

namespace {

// Bernstein basis of degree n at t.
double bernstein(int n, int k, double t) {
  double c = 1;
  for (int i = 1; i <= k; ++i) c = c * (n - k + i) / i;
  return c * std::pow(t, k) * std::pow(1 - t, n - k);
}

// Solves the n x n system a x = b (Gaussian elimination with partial pivoting).
std::vector<double> solve(std::vector<std::vector<double>> a, std::vector<double> b) {
  const std::size_t n = b.size();
  for (std::size_t c = 0; c < n; ++c) {
    std::size_t p = c;
    for (std::size_t r = c + 1; r < n; ++r)
      if (std::abs(a[r][c]) > std::abs(a[p][c])) p = r;
    std::swap(a[c], a[p]);
    std::swap(b[c], b[p]);
    for (std::size_t r = c + 1; r < n; ++r) {
      const double f = a[r][c] / a[c][c];
      for (std::size_t k = c; k < n; ++k) a[r][k] -= f * a[c][k];
      b[r] -= f * b[c];
    }
  }
  std::vector<double> x(n);
  for (std::size_t i = n; i-- > 0;) {
    double s = b[i];
    for (std::size_t k = i + 1; k < n; ++k) s -= a[i][k] * x[k];
    x[i] = s / a[i][i];
  }
  return x;
}

}  // namespace

double bezier_curve(const Hdr10PlusBezier& b, double x) {
  const double kx = b.knee_point_x / 4095.0, ky = b.knee_point_y / 4095.0;
  if (x <= kx) return kx > 0 ? ky / kx * x : ky;
  const double t = std::min((x - kx) / (1 - kx), 1.0);
  const int n = static_cast<int>(b.anchors.size()) + 1;
  double y = bernstein(n, n, t);
  for (int k = 1; k < n; ++k) y += bernstein(n, k, t) * b.anchors[static_cast<std::size_t>(k - 1)] / 1023.0;
  return ky + (1 - ky) * y;
}

namespace {

// One least-squares fit of the nine anchors for a knee at kx (on the identity, y = x src/tgt):
// ky + (1 - ky) B(t) against the EETF over x = kx + t (1 - kx), optionally weighted by
// 1/y (relative error, which the dark end of a log-like curve needs). Quantised, and made
// non-decreasing so the curve is monotonic.
Hdr10PlusBezier fit_anchors(const std::function<double(double)>& eetf, double src, double tgt, int knee_x, bool relative) {
  constexpr int kAnchors = 9, kDegree = kAnchors + 1, kSamples = 256;
  Hdr10PlusBezier b;
  b.knee_point_x = static_cast<std::uint16_t>(knee_x);
  const double kx = knee_x / 4095.0;
  b.knee_point_y = static_cast<std::uint16_t>(std::clamp(std::lround(kx * src / tgt * 4095), 0L, 4094L));
  const double ky = b.knee_point_y / 4095.0;
  std::vector<std::vector<double>> ata(kAnchors, std::vector<double>(kAnchors, 0.0));
  std::vector<double> atb(kAnchors, 0.0);
  for (int s = 1; s <= kSamples; ++s) {
    const double t = static_cast<double>(s) / kSamples;
    const double y = eetf(kx + t * (1 - kx));
    const double w = relative ? 1.0 / std::max(y, 1e-3) : 1.0;
    const double rhs = ((y - ky) / (1 - ky) - bernstein(kDegree, kDegree, t)) * w;
    std::array<double, kAnchors> row{};
    for (int k = 0; k < kAnchors; ++k) row[static_cast<std::size_t>(k)] = bernstein(kDegree, k + 1, t) * w;
    for (std::size_t i = 0; i < kAnchors; ++i) {
      atb[i] += row[i] * rhs;
      for (std::size_t j = 0; j < kAnchors; ++j) ata[i][j] += row[i] * row[j];
    }
  }
  long previous = 0;
  for (double p : solve(ata, atb)) {
    previous = std::max(previous, std::clamp(std::lround(p * 1023), 0L, 1023L));
    b.anchors.push_back(static_cast<std::uint16_t>(previous));
  }
  return b;
}

}  // namespace

std::optional<Hdr10PlusBezier> fit_bezier(double source_peak_nits, double target_peak_nits) {
  if (!(source_peak_nits > target_peak_nits) || !(target_peak_nits > 0)) return std::nullopt;
  const double src = std::min(source_peak_nits, 10000.0), tgt = target_peak_nits;
  // BT.2390 in nits: a display of paper white 1 makes the curve's relative units cd/m2.
  auto curve = tonemap::prepare("bt2390", tonemap::Display{tgt, 0.0, 1.0}, {{"source_peak_nits", std::max(src, 100.0)}});
  if (!curve) return std::nullopt;
  const std::shared_ptr<const tonemap::Curve> c = std::move(*curve);
  const auto eetf = [&](double x) { return std::min(c->map(x * src) / tgt, 1.0); };  // normalised in and out
  // The EETF is the identity below its knee KS = 1.5 maxLum - 0.5 (BT.2390-10 §5.4, PQ
  // normalised to the source). The basis curve's straight segment can stop anywhere below
  // it; where it stops decides how steep the Bezier must start (its slope is at most 10 at
  // t = 0), so the knee is searched for the smallest largest error in PQ.
  const double e_src = transfer::pq_inverse_eotf(src);
  const double ks = 1.5 * transfer::pq_inverse_eotf(tgt) / e_src - 0.5;
  const double knee_max = ks > 0 ? transfer::pq_eotf(ks * e_src) / src : 1.0 / 4095;
  std::optional<Hdr10PlusBezier> best;
  double best_error = INFINITY;
  constexpr int kKnees = 24;
  for (int i = 0; i < kKnees; ++i) {
    const double kx = std::exp(std::log(1.0 / 4095) + (std::log(std::max(knee_max, 2.0 / 4095)) - std::log(1.0 / 4095)) * i / (kKnees - 1));
    const int knee_x = std::clamp(static_cast<int>(std::lround(kx * 4095)), 1, 4094);
    for (bool relative : {false, true}) {
      Hdr10PlusBezier b = fit_anchors(eetf, src, tgt, knee_x, relative);
      double error = 0;
      for (int s = 1; s <= 200; ++s) {
        const double x = s / 200.0;
        error = std::max(error, std::abs(transfer::pq_inverse_eotf(bezier_curve(b, x) * tgt) - transfer::pq_inverse_eotf(eetf(x) * tgt)));
      }
      if (error < best_error) best_error = error, best = std::move(b);
    }
  }
  return best;
}

// ---- the sequence -------------------------------------------------------------------------

SequenceMetadata::SequenceMetadata(const DisplayTarget& target, const MasteringDisplay& mastering,
                                   const SequenceMetadataSettings& settings)
    : target_(target), mastering_(mastering), settings_(settings), pool_(std::make_shared<Pool>()) {}

Result<void> SequenceMetadata::add(const EncodedFrame& frame, bool scene_start) {
  if (frame.target.mode != target_.mode)
    return make_error("video.mode", fmt::format("frame {} is {}, the sequence {}", frames_, to_string(frame.target.mode),
                                                to_string(target_.mode)), "display.mode");
  return add(light_of(frame), scene_start);
}

FrameLight SequenceMetadata::light_of(const EncodedFrame& frame) const {
  if (has_dynamic_metadata()) return measure_frame_light(frame);
  // HLG and SDR need the content light alone, which the encoder measured with the frame
  // (HLG's per-pixel OOTF makes a second decode cost ~20 ns a pixel).
  FrameLight light;
  light.max_nits = frame.content_light.max_cll_nits;
  light.mean_nits = frame.content_light.max_fall_nits;
  return light;
}

Result<void> SequenceMetadata::add(const FrameLight& light, bool scene_start) {
  if (finished_) return make_error("video.metadata", "frame added after the sequence was finished");
  if (frames_ > 0 && scene_start) close_scene();
  if (frames_ == 0 || scene_start) scenes_.push_back({frames_, frames_});
  scenes_.back().last_frame = frames_;
  content_light_.max_cll_nits = std::max(content_light_.max_cll_nits, light.max_nits);
  content_light_.max_fall_nits = std::max(content_light_.max_fall_nits, light.mean_nits);
  pool_->scene.add(light);
  if (settings_.granularity == MetadataGranularity::frame) {
    const FrameLight* one = &light;
    frame_light_.push_back(summarise(std::span<const FrameLight* const>(&one, 1)));
  }
  ++frames_;
  return {};
}

void SequenceMetadata::close_scene() {
  if (scene_light_.size() == scenes_.size()) return;
  scene_light_.push_back(pool_->scene.summary());
  pool_->scene = Totals{};
  std::optional<Hdr10PlusBezier> curve;
  if (settings_.hdr10plus_target_nits) curve = fit_bezier(scene_light_.back().max_nits, *settings_.hdr10plus_target_nits);
  scene_curve_.push_back(std::move(curve));
}

void SequenceMetadata::finish() {
  if (finished_) return;
  if (!scenes_.empty()) close_scene();
  finished_ = true;
  pool_.reset();
}

int SequenceMetadata::scene_of(int frame) const {
  auto it = std::upper_bound(scenes_.begin(), scenes_.end(), frame,
                             [](int f, const SceneRange& s) { return f < s.first_frame; });
  return static_cast<int>(it - scenes_.begin()) - 1;
}

const LightSummary& SequenceMetadata::light(int frame) const {
  if (settings_.granularity == MetadataGranularity::frame) return frame_light_.at(static_cast<std::size_t>(frame));
  return scene_light_.at(static_cast<std::size_t>(scene_of(frame)));
}

Hdr10PlusFrame SequenceMetadata::hdr10plus(int frame) const {
  Hdr10PlusFrame m = hdr10plus_from(light(frame));
  if (settings_.hdr10plus_target_nits) {
    // Profile B throughout (x265 needs one profile per file): the scene's curve, or none
    // where the scene fits the target display.
    m.targeted_system_display_maximum_luminance = static_cast<std::uint32_t>(std::lround(*settings_.hdr10plus_target_nits));
    m.bezier = scene_curve_.at(static_cast<std::size_t>(scene_of(frame)));
  }
  return m;
}

DoviL1 SequenceMetadata::dovi_l1(int frame) const { return dovi_l1_from(light(frame)); }

nlohmann::json SequenceMetadata::hdr10plus_json() const {
  nlohmann::json scenes = nlohmann::json::array(), first = nlohmann::json::array(), count = nlohmann::json::array();
  for (std::size_t s = 0; s < scenes_.size(); ++s) {
    const SceneRange& r = scenes_[s];
    first.push_back(r.first_frame);
    count.push_back(r.last_frame - r.first_frame + 1);
    for (int f = r.first_frame; f <= r.last_frame; ++f)
      scenes.push_back(hdr10plus_json_entry(hdr10plus(f), static_cast<int>(s), f - r.first_frame, f));
  }
  return {{"JSONInfo", {{"HDR10plusProfile", settings_.hdr10plus_target_nits ? "B" : "A"}, {"Version", "1.0"}}},
          {"SceneInfo", scenes},
          {"SceneInfoSummary", {{"SceneFirstFrameIndex", first}, {"SceneFrameNumbers", count}}},
          {"ToolInfo", {{"Tool", "hdrd"}, {"Version", HDRD_VERSION_STRING}}}};
}

nlohmann::json SequenceMetadata::dovi_json() const {
  auto l1 = [](const DoviL1& v) {
    return nlohmann::json::array({{{"Level1", {{"min_pq", v.min_pq}, {"max_pq", v.max_pq}, {"avg_pq", v.avg_pq}}}}});
  };
  const io::Cta861Light cll = io::cta861_light(content_light_, mastering_);
  nlohmann::json shots = nlohmann::json::array();
  for (std::size_t s = 0; s < scenes_.size(); ++s) {
    const SceneRange& r = scenes_[s];
    nlohmann::json shot{{"start", r.first_frame},
                        {"duration", r.last_frame - r.first_frame + 1},
                        {"metadata_blocks", l1(dovi_l1_from(scene_light_[s]))}};
    if (settings_.granularity == MetadataGranularity::frame) {
      nlohmann::json edits = nlohmann::json::array();
      for (int f = r.first_frame; f <= r.last_frame; ++f)
        edits.push_back({{"edit_offset", f - r.first_frame}, {"metadata_blocks", l1(dovi_l1(f))}});
      shot["frame_edits"] = edits;
    }
    shots.push_back(shot);
  }
  // Level 6 (dovi_tool): mastering max in cd/m2, min in 0.0001 cd/m2, MaxCLL/MaxFALL in cd/m2.
  return {{"cm_version", "V40"},
          {"profile", "8.1"},
          {"length", frames_},
          {"level6",
           {{"max_display_mastering_luminance", io::to_units(mastering_.max_nits, 1, 10000, false)},
            {"min_display_mastering_luminance", io::to_units(mastering_.min_nits, 0.0001, 65535, false)},
            {"max_content_light_level", cll.max_cll},
            {"max_frame_average_light_level", cll.max_fall}}},
          {"shots", shots}};
}

}  // namespace hdrd::video

#include "job/sequence.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <mutex>
#include <regex>
#include <thread>

#include <unistd.h>

#include <fmt/format.h>

#include "display/presenter.hpp"
#include "display/sequence_presenter.hpp"
#include "encode/io/file_sequence.hpp"
#include "encode/io/io.hpp"
#include "encode/parallel.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/temporal.hpp"
#include "encode/video/sequence_metadata.hpp"
#include "encode/video/writer.hpp"
#include "job/build.hpp"
#include "shading/renderer.hpp"
#include "shading/scene_loader.hpp"

namespace hdrd::job {
namespace fs = std::filesystem;

// ---- the frames of an EXR sequence -------------------------------------------------------

bool names_a_sequence(const fs::path& spec) { return io::names_a_file_sequence(spec); }

Result<std::vector<fs::path>> exr_sequence_files(const fs::path& spec, const io::InputFiles& files) {
  if (spec.empty()) return make_error("input.sequence", "a sequence of EXR frames is needed (a pattern, a directory or a list file)", "images");
  io::FileSequenceRules rules;
  rules.files = files;
  return io::file_sequence(spec, rules);
}

bool sets_sequence_settings(const nlohmann::json& request) {
  if (!request.is_object()) return false;
  for (const auto& s : settings()) {
    if (!s.sequence) continue;
    const nlohmann::json* node = &request;
    std::string_view rest = s.path;
    while (node && node->is_object()) {
      const auto dot = rest.find('.');
      const auto it = node->find(std::string(rest.substr(0, dot)));
      if (it == node->end()) {
        node = nullptr;
        break;
      }
      if (dot == std::string_view::npos) return true;
      node = &*it;
      rest = rest.substr(dot + 1);
    }
  }
  return false;
}

// ---- the sequence ------------------------------------------------------------------------

namespace {

Result<std::string> read_text(const fs::path& p, std::uintmax_t max_bytes = 1u << 30) {
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  if (ec) return make_error("io.read", fmt::format("cannot read {}: {}", p.string(), ec.message()));
  if (size > max_bytes) return make_error("io.read", fmt::format("{} is larger than {} bytes", p.string(), max_bytes));
  std::ifstream in(p, std::ios::binary);
  std::string text(static_cast<std::size_t>(size), '\0');
  if (!in.read(text.data(), static_cast<std::streamsize>(size)))
    return make_error("io.read", fmt::format("cannot read {}", p.string()));
  return text;
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The frame rate as the container's rational: NTSC rates exactly (24000/1001, ...).
std::pair<int, int> rational_fps(double fps) {
  for (int base : {24, 30, 48, 60, 120, 240})
    if (std::abs(fps - base * 1000.0 / 1001.0) < 5e-4) return {base * 1000, 1001};
  if (std::abs(fps - std::round(fps)) < 1e-9) return {static_cast<int>(std::round(fps)), 1};
  return {static_cast<int>(std::round(fps * 1000)), 1000};
}

Result<std::optional<video::VideoSettings>> video_settings(const FrameRequest& r) {
  if (r.is_null("video.codec")) {
    // Read so that the "every setting is used" check sees them: they only matter with a codec.
    for (const auto& s : settings())
      if (s.path.rfind("video.", 0) == 0) r.at(s.path);
    return std::optional<video::VideoSettings>();
  }
  video::VideoSettings v;
  v.codec = video::parse_codec(r.text("video.codec")).value_or(video::Codec::hevc);
  v.container = video::parse_container(r.text("video.container")).value_or(video::Container::mp4);
  v.crf = r.optional_number("video.crf");
  v.preset = r.text("video.preset");
  v.lossless = r.boolean("video.lossless");
  v.range = parse_range(r.text("video.range")).value_or(Range::narrow);
  std::tie(v.fps_num, v.fps_den) = rational_fps(r.number("fps"));
  v.keyframe_interval_s = r.number("video.keyframe_interval_s");
  v.threads = static_cast<int>(r.integer("video.threads"));
  v.av1_encoder = r.text("video.av1_encoder");
  v.dynamic_metadata = r.boolean("video.dynamic_metadata");
  if (auto ok = video::validate(v); !ok) return ok.error();
  return std::optional<video::VideoSettings>(v);
}

video::SequenceMetadataSettings metadata_settings(const FrameRequest& r) {
  video::SequenceMetadataSettings s;
  s.granularity = video::parse_granularity(r.text("metadata.granularity")).value_or(s.granularity);
  s.hdr10plus_target_nits = r.optional_number("metadata.hdr10plus_target_nits");
  return s;
}

}  // namespace

temporal::TemporalSettings temporal_settings(const FrameRequest& r) {
  // adaptation_time_s, when given, sets both directions; a direction given itself wins;
  // otherwise each direction's table default (the eye's fast adaptation to light, slow to
  // the dark: Unreal's speed up 3 and down 1).
  exposure::Settings e;
  const std::optional<double> both = r.optional_number("exposure.adaptation_time_s");
  auto direction = [&](std::string_view path) {
    return r.has(path) || !both ? r.optional_number(path) : both;
  };
  e.adaptation_time_s = both.value_or(0);
  e.adaptation_brighten_time_s = direction("exposure.adaptation_brighten_time_s");
  e.adaptation_darken_time_s = direction("exposure.adaptation_darken_time_s");
  temporal::TemporalSettings t;
  t.adaptation = temporal::adaptation_settings(e);
  t.scene_cut.threshold_stops = r.number("sequence.cut_threshold_stops");
  t.detect_cuts = r.boolean("sequence.detect_cuts");
  t.peak.percentile = r.number("tone.peak_percentile");
  t.peak.rise_time_s = r.number("tone.peak_rise_time_s");
  t.peak.fall_time_s = r.number("tone.peak_fall_time_s");
  return t;
}

namespace {

// Frames between the render/encode stage and the writer: push blocks while full, pop while
// empty; close() ends both sides (an error on either).
template <class T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : capacity_(std::max<std::size_t>(1, capacity)) {}
  bool push(T item) {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    if (closed_) return false;
    items_.push_back(std::move(item));
    cv_.notify_all();
    return true;
  }
  std::optional<T> pop() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return closed_ || done_ || !items_.empty(); });
    if (closed_ || items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    cv_.notify_all();
    return item;
  }
  void finish() {  // the producer is done: pop drains what is left
    std::lock_guard lock(mu_);
    done_ = true;
    cv_.notify_all();
  }
  void close() {  // stop now
    std::lock_guard lock(mu_);
    closed_ = true;
    items_.clear();
    cv_.notify_all();
  }

 private:
  std::size_t capacity_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<T> items_;
  bool done_ = false, closed_ = false;
};

struct FrameItem {
  int index = 0;
  double time_s = 0;
  temporal::FrameDecision decision;
  std::optional<double> source_peak_nits;  // when the curve took the detected peak
  std::optional<double> source_avg_nits;   // when it took the scene average too
  double duration_s = 0;                   // the scene's animation (a render)
  std::string input;                       // an encode's EXR
  FrameResult result;
};

std::string frame_base(const fs::path& outbase, int index) { return fmt::format("{}.{:05d}", outbase.string(), index); }

// The sidecar entry of one frame.
nlohmann::json frame_entry(const FrameItem& item, int scene) {
  const EncodedFrame& f = item.result.frame;
  nlohmann::json entry = {{"index", item.index},
                          {"time_s", item.time_s},
                          {"scene", scene},
                          {"scene_start", item.decision.scene_start},
                          {"exposure_scale", f.settings.contains("exposure") ? f.settings["exposure"].value("scale", 0.0)
                                                                            : item.decision.exposure_scale},
                          {"metered_exposure_scale", item.decision.own_scale},
                          {"cut_distance_stops", item.decision.cut_distance_stops},
                          {"max_cll_nits", f.content_light.max_cll_nits},
                          {"frame_average_nits", f.content_light.max_fall_nits}};
  if (item.source_peak_nits) entry["source_peak_nits"] = *item.source_peak_nits;
  if (item.source_avg_nits) entry["source_avg_nits"] = *item.source_avg_nits;
  if (!item.input.empty()) entry["input"] = item.input;
  return entry;
}

// What the writer stage knows at the end, for the sequence's outputs.
struct SequenceSummary {
  nlohmann::json first_sidecar;           // io::sidecar_json of frame 0: the target and signal fields
  nlohmann::json present;                 // live output's statistics (present.live), else null
  nlohmann::json frames = nlohmann::json::array();
  std::vector<std::string> frame_kinds;  // per-frame dump kinds ("raw", "sidecar", ...)
  std::vector<std::string> warnings;
  nlohmann::json timings = nlohmann::json::object();
};

// OUTBASE.json, OUTBASE.hdr10plus.json and OUTBASE.dovi.json (hdr10), all or nothing. The
// one composition of the sequence's outputs: a one-process run and a merge of shards.
Result<SequenceResult> write_sequence_outputs(const FrameRequest& request, const fs::path& outbase, double fps,
                                              const SequenceSummary& sum, const video::SequenceMetadata& metadata,
                                              const std::optional<video::VideoResult>& video) {
  SequenceResult out;
  nlohmann::json j = sum.first_sidecar;
  j["format"] = "hdrd-sequence";
  j["format_version"] = 1;
  j["fps"] = fps;
  j["frame_count"] = sum.frames.size();
  j["duration_s"] = sum.frames.size() / fps;
  j["frames"] = sum.frames;
  nlohmann::json scenes = nlohmann::json::array();
  for (const auto& s : metadata.scenes()) scenes.push_back({{"first_frame", s.first_frame}, {"last_frame", s.last_frame}});
  j["scenes"] = scenes;
  // CTA-861.3 over the whole sequence: the largest pixel and the largest frame average.
  const ContentLightLevel measured = metadata.content_light();
  const bool hdr = j.value("mode", "") == "hdr10" || j.value("mode", "") == "hlg" || j.value("mode", "") == "scrgb";
  const CarriedLightLevel carried = hdr ? carried_light_level(measured, metadata.mastering()) : CarriedLightLevel{};
  j["content_light_level"] = {{"max_cll_nits", carried.max_cll_nits},
                              {"max_fall_nits", carried.max_fall_nits},
                              {"max_cll_nits_measured", measured.max_cll_nits},
                              {"max_fall_nits_measured", measured.max_fall_nits}};
  j.erase("settings");
  j["settings"] = {{"request", request.canonical()}};
  std::vector<std::string> warnings = sum.warnings;
  if (video) warnings.insert(warnings.end(), video->warnings.begin(), video->warnings.end());
  j["warnings"] = warnings;
  if (!sum.present.is_null()) j["present"] = sum.present;
  nlohmann::json files = nlohmann::json::object();
  const std::string stem = outbase.filename().string();
  for (const auto& kind : sum.frame_kinds) {
    const std::string ext = kind == "sidecar" ? std::string(kSidecarSuffix) : std::string(find_output(kind)->suffix);
    files["frames"][kind] = fmt::format("{}.%05d{}", stem, ext);
    out.files["frames." + kind] = fmt::format("{}.%05d{}", outbase.string(), ext);
  }
  std::vector<std::string> texts;
  std::vector<fs::path> paths;
  auto add = [&](const std::string& kind, const std::string& suffix, std::string text) {
    paths.push_back(outbase.string() + suffix);
    texts.push_back(std::move(text));
    files[kind] = paths.back().filename().string();
    out.files[kind] = paths.back().string();
  };
  if (metadata.has_dynamic_metadata()) {
    add("hdr10plus", std::string(kHdr10PlusSuffix), metadata.hdr10plus_json().dump(2) + "\n");
    add("dovi", std::string(kDoviSuffix), metadata.dovi_json().dump(2) + "\n");
  }
  nlohmann::json timings = sum.timings;
  if (video) {
    timings["video_ycbcr"] = video->convert_ms;
    timings["video_ycbcr_cpu"] = video->convert_cpu_ms;
    timings["video_encoder"] = video->encoder_ms;
    timings["video_mux"] = video->mux_ms;
    nlohmann::json vj = video->to_json();
    vj["file"] = video->path.filename().string();
    j["video"] = vj;
    files["video"] = video->path.filename().string();
    out.files["video"] = video->path.string();
  }
  const fs::path sidecar = outbase.string() + std::string(kSidecarSuffix);
  files["sidecar"] = sidecar.filename().string();
  j["files"] = files;
  j["timings_ms"] = timings;
  paths.push_back(sidecar);
  texts.push_back(j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  std::vector<io::FileToWrite> writes;
  for (std::size_t i = 0; i < paths.size(); ++i)
    writes.push_back({paths[i], std::span(reinterpret_cast<const std::uint8_t*>(texts[i].data()), texts[i].size())});
  if (auto ok = io::write_all_or_nothing(writes, {.durable = request.boolean("durable")}); !ok) return ok.error();
  out.files["sidecar"] = sidecar.string();
  out.sidecar = std::move(j);
  out.frames = static_cast<int>(sum.frames.size());
  out.warnings = warnings;
  out.timings_ms = std::move(timings);
  return out;
}

nlohmann::json light_json(const FrameLight& l) {
  nlohmann::json counts = nlohmann::json::object();  // sparse: hdr10 fills at most 1024 levels
  for (std::size_t i = 0; i < l.pq_counts.size(); ++i)
    if (l.pq_counts[i]) counts[std::to_string(i)] = l.pq_counts[i];
  return {{"max_channel_nits", l.max_channel_nits}, {"max_nits", l.max_nits}, {"mean_nits", l.mean_nits},
          {"min_nits", l.min_nits}, {"pixels", l.pixels}, {"pq_counts", counts}};
}

Result<FrameLight> light_from_json(const nlohmann::json& j) {
  try {
    FrameLight l;
    l.max_channel_nits = j.at("max_channel_nits").get<std::array<double, 3>>();
    l.max_nits = j.at("max_nits").get<double>();
    l.mean_nits = j.at("mean_nits").get<double>();
    l.min_nits = j.at("min_nits").get<double>();
    l.pixels = j.at("pixels").get<std::uint64_t>();
    for (const auto& [k, v] : j.at("pq_counts").items()) {
      const std::size_t bin = std::stoul(k);
      if (bin >= l.pq_counts.size()) return make_error("sequence.shard", "a light level outside the 12-bit PQ range");
      l.pq_counts[bin] = v.get<std::uint32_t>();
    }
    return l;
  } catch (const std::exception& e) {
    return make_error("sequence.shard", std::string("a frame's light is malformed: ") + e.what());
  }
}

// The writer stage: per-frame dumps, the video encoder, the metadata, live output. In a
// shard (SequenceOptions::shard) it writes a video segment and the frames' statistics into
// the work dir instead of the sequence's outputs (job/sequence_plan.cpp merges them).
class SequenceSink {
 public:
  SequenceSink(const FrameRequest& r, const fs::path& outbase, const SequenceOptions& options,
               std::optional<video::VideoSettings> video, int total)
      : request_(r), outbase_(outbase), options_(options), video_settings_(std::move(video)), total_(total) {}
  ~SequenceSink() {
    if (!finished_) remove_written();
    if (!staging_.empty()) {
      std::error_code ec;
      fs::remove_all(staging_, ec);
    }
  }

  Result<void> consume(FrameItem item) {
    const auto t0 = Clock::now();
    const EncodedFrame& f = item.result.frame;
    if (!metadata_) {
      metadata_.emplace(f.target, f.mastering, metadata_settings(request_));
      sum_.first_sidecar = io::sidecar_json(f, {});
      if (video_settings_) {
        auto w = video::SequenceWriter::open(video_base(), *video_settings_, {f.width, f.height, f.target, f.mastering});
        if (!w) return w.error();
        writer_ = std::move(*w);
      }
    }
    if (!item.result.files.empty()) {
      if (!options_.shard && staging_.empty()) {  // the per-frame files wait there until the end
        auto staging = io::make_staging_dir(outbase_);
        if (!staging) return staging.error();
        staging_ = std::move(*staging);
      }
      auto written = write_outputs(item.result, frame_base(dumps_base(), item.index));
      if (!written) return written.error();
      const bool first = sum_.frames.empty();
      for (const auto& [kind, path] : *written) {
        written_.push_back(path);
        if (first) sum_.frame_kinds.push_back(kind);
      }
    }
    add_time("dumps", t0);
    const bool start = item.decision.scene_start;
    const auto t1 = Clock::now();
    const CpuMeter metadata_cpu;
    const FrameLight light = metadata_->light_of(f);
    if (options_.shard)  // the merge adds the shards' lights to the sequence's metadata
      lights_.push_back(light_json(light));
    else if (auto ok = metadata_->add(light, start); !ok)
      return ok.error();
    add_time("metadata", t1);
    add_ms("metadata_cpu", metadata_cpu.ms());
    if (writer_) {
      const auto t2 = Clock::now();
      if (auto ok = writer_->write(f, {.keyframe = start}); !ok) return ok.error();
      add_time("video", t2);
    }
    if (options_.on_frame)
      if (auto ok = options_.on_frame(f, item.index); !ok) return ok.error();
    // Scenes are numbered over the whole sequence: a shard counts the ones before it.
    scene_ = start ? scene_ + 1 : scene_;
    sum_.frames.push_back(frame_entry(item, scene_));
    for (const auto& w : item.result.warnings)
      if (std::find(sum_.warnings.begin(), sum_.warnings.end(), w) == sum_.warnings.end()) sum_.warnings.push_back(w);
    for (const auto& [stage, ms] : item.result.timings_ms.items())
      if (ms.is_number()) sum_.timings[stage] = sum_.timings.value(stage, 0.0) + ms.get<double>();
    if (options_.progress) {
      SequenceProgress p;
      p.frames_done = static_cast<int>(sum_.frames.size());
      p.frames_total = total_;
      p.elapsed_s = seconds_since(start_);
      p.fps = p.elapsed_s > 0 ? p.frames_done / p.elapsed_s : 0;
      p.eta_s = p.fps > 0 ? (total_ - p.frames_done) / p.fps : 0;
      options_.progress(p);
    }
    return {};
  }

  // A shard's scene numbers continue the sequence's: `scenes` started before its first frame.
  void set_scenes_before(int scenes) { scene_ = scenes - 1; }
  void set_total(int total) { total_ = total; }  // before the first frame is consumed
  void set_present(nlohmann::json stats) { sum_.present = std::move(stats); }

  Result<SequenceResult> finish(double fps) {
    if (!metadata_) return make_error("internal", "a sequence finished without frames");
    if (options_.shard) return finish_shard();
    metadata_->finish();
    if (auto ok = commit_staged_frames(); !ok) return ok.error();
    std::optional<video::VideoResult> video;
    if (writer_) {
      const auto t0 = Clock::now();
      auto v = writer_->finish(&*metadata_);
      if (!v) return v.error();
      add_time("video", t0);
      written_.push_back(v->path.string());
      video = std::move(*v);
    }
    auto out = write_sequence_outputs(request_, outbase_, fps, sum_, *metadata_, video);
    if (!out) return out.error();
    finished_ = true;
    if (!staging_.empty()) {  // the commit: the journal goes, every file is final
      std::error_code ec;
      fs::remove_all(staging_, ec);
      staging_.clear();
    }
    return out;
  }

 private:
  // A shard: the segment, then its statistics, then shard-I.done last (what the engines and
  // the merge look for). No times in them: a retried shard writes the same bytes.
  Result<SequenceResult> finish_shard() {
    const ShardSpec& sh = *options_.shard;
    const fs::path base = sh.work_dir / fmt::format("shard-{}", sh.shard);
    if (writer_)
      if (auto ok = writer_->finish_segment(base.string() + ".segment"); !ok) return ok.error();
    written_.push_back(base.string() + ".segment");
    nlohmann::json stats = {{"format", "hdrd-sequence-shard"},
                            {"format_version", 1},
                            {"fingerprint", sh.fingerprint},
                            {"shard", sh.shard},
                            {"first_frame", sh.first_frame},
                            {"frame_count", sum_.frames.size()},
                            {"first_sidecar", sum_.first_sidecar},
                            {"frames", sum_.frames},
                            {"lights", lights_},
                            {"frame_kinds", sum_.frame_kinds},
                            {"warnings", sum_.warnings},
                            {"segment", writer_ ? nlohmann::json(base.filename().string() + ".segment") : nlohmann::json()}};
    const std::string text = stats.dump(1) + "\n", done = sh.fingerprint + "\n";
    const fs::path stats_path = base.string() + ".json", done_path = sh.work_dir / fmt::format("shard-{}.done", sh.shard);
    if (auto ok = io::atomic_write(stats_path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()),
                                   {.durable = true});
        !ok)
      return ok.error();
    written_.push_back(stats_path.string());
    if (auto ok = io::atomic_write(done_path, std::span(reinterpret_cast<const std::uint8_t*>(done.data()), done.size()),
                                   {.durable = true});
        !ok)
      return ok.error();
    SequenceResult out;
    out.sidecar = std::move(stats);
    out.frames = static_cast<int>(sum_.frames.size());
    out.files = {{"stats", stats_path.string()}, {"done", done_path.string()}};
    if (writer_) out.files["segment"] = base.string() + ".segment";
    out.warnings = sum_.warnings;
    out.timings_ms = sum_.timings;
    finished_ = true;
    return out;
  }

  // The sequence is done: the journal names every final file it will have (so that a start-up
  // sweep after a crash from here on removes them: io::sweep_staging), then the per-frame
  // files move from the staging directory to their final names.
  Result<void> commit_staged_frames() {
    if (staging_.empty()) return {};
    const fs::path dir = outbase_.parent_path();
    const std::string stem = outbase_.filename().string();
    std::vector<std::pair<fs::path, fs::path>> moves;
    std::vector<std::string> journal;
    for (auto& p : written_) {
      const fs::path from = p, to = dir / from.filename();
      moves.emplace_back(from, to);
      journal.push_back(to.filename().string());
      p = to.string();  // from here on, cleaning up removes the final name (a rename not made leaves a staged file)
    }
    for (const auto& suffix : owned_suffixes())
      if (suffix.find(kFrameNumber) == std::string::npos) journal.push_back(stem + suffix);
    for (const auto container : {video::Container::mp4, video::Container::mkv})
      journal.push_back(stem + std::string(video::file_extension(container)));
    return io::commit_staged(staging_, journal, moves);
  }

  // Where a shard puts what the merge will move: the work dir; a sequence's per-frame files
  // wait in its staging directory until it is done.
  fs::path dumps_base() const {
    return options_.shard ? options_.shard->work_dir / "frames" / "frame" : staging_ / outbase_.filename();
  }
  fs::path video_base() const {
    return options_.shard ? options_.shard->work_dir / fmt::format("shard-{}", options_.shard->shard) : outbase_;
  }
  void add_ms(const char* stage, double ms) { sum_.timings[stage] = sum_.timings.value(stage, 0.0) + ms; }
  void add_time(const char* stage, Clock::time_point t0) { add_ms(stage, seconds_since(t0) * 1e3); }
  void remove_written() {
    if (writer_) writer_->cancel();
    std::error_code ec;
    for (const auto& p : written_) fs::remove(p, ec);
  }

  const FrameRequest& request_;
  fs::path outbase_;
  const SequenceOptions& options_;
  std::optional<video::VideoSettings> video_settings_;
  int total_ = 0;
  Clock::time_point start_ = Clock::now();
  std::optional<video::SequenceMetadata> metadata_;
  std::unique_ptr<video::SequenceWriter> writer_;
  SequenceSummary sum_;
  nlohmann::json lights_ = nlohmann::json::array();
  std::vector<std::string> written_;
  fs::path staging_;  // DIR/.NAME.staging-XXXXXXXXXXXX while per-frame files are written
  int scene_ = -1;
  bool finished_ = false;
};

// The outputs of each frame: the request's formats; without formats, the mode's default
// dump when there is no video, else none (the video is the sequence's output).
Result<std::vector<Output>> frame_outputs(const FrameRequest& r, Mode mode, bool video) {
  if (r.has("formats")) return outputs_from_names(r.list("formats"), r.source, mode);
  if (video) return std::vector<Output>{};
  return default_outputs(r.source, mode);
}

// Where the frames come from: a render's times or an encode's files.
struct FrameSource {
  int total = 1;
  bool total_from_scene = false;  // a render without `frames`: the animation's length, known at frame 0
  double fps = 24, start_s = 0;
  std::vector<fs::path> inputs;  // encode
};

Result<FrameSource> frame_source(const FrameRequest& request, const io::InputFiles& files = {}) {
  if (!request.sequence) return make_error("internal", "run_sequence needs a request parsed as a sequence");
  if (request.source == Source::pattern) return make_error("request.value", "patterns have no sequence form", "frames");
  FrameSource src;
  src.fps = request.number("fps");
  src.total = request.is_null("frames") ? 1 : static_cast<int>(request.integer("frames"));
  if (request.source == Source::encode) {
    auto found = exr_sequence_files(request.text("images"), files);
    if (!found) return found.error();
    if (!request.is_null("frames") && src.total > static_cast<int>(found->size()))
      return make_error("request.value",
                        fmt::format("frames: {} asked, {} has {}", src.total, request.text("images"), found->size()),
                        "frames");
    if (request.is_null("frames")) src.total = static_cast<int>(found->size());
    found->resize(static_cast<std::size_t>(src.total));
    src.inputs = std::move(*found);
  } else {
    src.start_s = request.number("start_s");
    src.total_from_scene = request.is_null("frames");
  }
  return src;
}

// A render without `frames` covers the scene's animation, its first and last key included
// (a still scene: one frame).
int frames_of_animation(double duration_s, double fps) {
  if (!(duration_s > 0) || !std::isfinite(duration_s)) return 1;
  return static_cast<int>(std::min(1e6, std::round(duration_s * fps) + 1));
}

// The statistics a cut and the peak are decided on, when the exposure did not meter the
// frame itself (manual, camera, light): a coarser subsample than metering's ~2 Mpx, as
// cheap as the decisions need (the 99.99th percentile still rests on ~26 samples).
constexpr std::size_t kTemporalSamples = 1u << 18;

// A sentinel: the analysis stops a frame job once the frame is decided.
constexpr const char* kAnalysed = "sequence.analysed";

// Runs frames [first, first + count) of the sequence: each frame's job, its decision (in
// line from `tone`, or from the track), then `consume` (the writer stage, on its thread,
// through the bounded queue) unless analysing.
struct FrameLoop {
  const FrameRequest& request;
  const SequenceOptions& options;
  const FrameSource& src;
  shading::Renderer* renderer;
  temporal::TemporalTone* tone = nullptr;                      // in line
  const std::vector<temporal::FrameDecision>* track = nullptr;  // decided before (a plan)
  std::vector<temporal::FrameDecision>* decided = nullptr;      // analysis: the decisions
  // The UI and the grade, loaded by the first frame (frames run one at a time).
  std::shared_ptr<LoadedResources> resources = std::make_shared<LoadedResources>();
};

Result<void> decide(const FrameLoop& loop, FrameItem& item, const SceneInput& in, PreparedPipeline& p,
                    const FrameFacts& facts) {
  item.duration_s = facts.duration_s;
  temporal::FrameDecision d;
  if (loop.track) {
    d = (*loop.track)[static_cast<std::size_t>(item.index)];
  } else {
    // The samples the exposure metered, when it read the image (the same ones, once).
    std::shared_ptr<const std::vector<float>> lum = p.luminance_nits;
    if (!lum) lum = std::make_shared<const std::vector<float>>(scene_luminance_nits(in, p.unit_nits, kTemporalSamples));
    auto next = loop.tone->next_metered(*lum, p.metering.scale, 1.0 / loop.src.fps, facts.scene_cut);
    if (!next) return next.error();
    d = *next;
  }
  // Manual and camera exposure are what the request (or the scene's keyframes) says, frame
  // by frame: exactly each frame's single-frame encode. Metered modes adapt.
  const auto mode = p.settings.exposure.mode;
  if (mode != exposure::Mode::manual && mode != exposure::Mode::camera) set_exposure_scale(p, d.exposure_scale);
  const std::string_view param = p.curve_info ? source_peak_param(*p.curve_info) : std::string_view();
  if (loop.request.boolean("tone.dynamic_peak") && !param.empty()) {
    // Each of the peak and the scene average follows the frames unless tone.params sets it.
    const auto& given = loop.request.at("tone.params");
    const std::string_view avg = source_average_param(*p.curve_info);
    std::optional<double> peak, average;
    if (!given.contains(std::string(param))) peak = d.source_peak;
    if (!avg.empty() && !given.contains(std::string(avg)) && d.source_average > 0) average = d.source_average;
    if (auto ok = set_source_peak(p, peak, average); !ok) return ok.error();
    if (peak) item.source_peak_nits = *peak * p.settings.target.paper_white_nits;
    if (average) item.source_avg_nits = *average * p.settings.target.paper_white_nits;
  }
  item.decision = d;
  if (loop.decided) {
    loop.decided->push_back(d);
    return make_error(kAnalysed, "analysed");
  }
  return {};
}

// Runs the frames; `on_total` hears the frame count once frame 0 has told it (a render
// without `frames`).
template <class Sink>
Result<void> run_frames(const FrameLoop& loop, int first, int count, std::optional<std::vector<Output>> outputs,
                        Sink&& start_sink, BoundedQueue<FrameItem>& queue, const std::function<bool()>& failed,
                        const std::function<void(int)>& on_total) {
  const double dt = 1.0 / loop.src.fps;
  for (int i = first; i < first + count && !failed(); ++i) {
    if (loop.options.job.should_stop && loop.options.job.should_stop()) return make_error("request.cancelled", "cancelled");
    FrameItem item;
    item.index = i;
    item.time_s = loop.src.start_s + i * dt;
    JobOptions jo = loop.options.job;
    jo.resources = loop.resources;
    jo.time_s = item.time_s;
    if (i > 0) jo.previous_time_s = item.time_s - dt;
    jo.temporal = [&](const SceneInput& in, PreparedPipeline& p, const FrameFacts& facts) {
      return decide(loop, item, in, p, facts);
    };
    EncodeInput input;
    if (loop.request.source == Source::encode) {
      input.path = loop.src.inputs[static_cast<std::size_t>(i)];
      item.input = input.path.filename().string();
    }
    const std::string where = loop.request.source == Source::encode ? fmt::format("frame {} ({}): ", i, item.input)
                                                                     : fmt::format("frame {} (t = {:g} s): ", i, item.time_s);
    auto job = FrameJob::create(loop.request, std::move(jo), input, outputs);
    if (!job) return job.error();
    if (!outputs) {
      auto o = frame_outputs(loop.request, (*job)->target().mode, !loop.request.is_null("video.codec"));
      if (!o) return o.error();
      outputs = *o;
      if (auto ok = (*job)->set_outputs(*outputs); !ok) return ok.error();
      start_sink();
    }
    auto result = run_frame_job(**job, loop.renderer);
    if (!result && result.error().code != kAnalysed) {
      Error e = result.error();
      e.message = where + e.message;
      return e;
    }
    if (i == 0 && loop.src.total_from_scene) {
      count = frames_of_animation(item.duration_s, loop.src.fps);
      on_total(count);
    }
    if (!result) continue;  // analysed
    item.result = std::move(*result);
    if (!queue.push(std::move(item))) break;
  }
  return {};
}

}  // namespace

namespace {

// The setting an up-front error is about, as the front end spells it, leads its message
// (`--width/--height: 4:2:0 video needs an even width and height, not 95x64`): the CLI
// reported these as `frame 0 (t = 0 s): ...` after rendering frame 0 (issue 29.13).
Error naming_setting(Error e, Spelling spelling) {
  if (e.field.empty()) return e;
  std::string name;
  if (e.field == "size") name = label("width", spelling) + "/" + label("height", spelling);
  else if (e.field == "output") name = spelling == Spelling::cli ? "-o" : "output";
  else name = label(e.field, spelling);
  if (e.message.rfind(name, 0) != 0) e.message = name + ": " + e.message;
  return e;
}

}  // namespace

Result<void> check_output_base(const fs::path& outbase) {
  if (outbase.empty() || !outbase.has_filename())
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  const fs::path dir = outbase.has_parent_path() ? outbase.parent_path() : fs::path(".");
  std::error_code ec;
  const auto st = fs::status(dir, ec);
  if (ec || !fs::exists(st))
    return make_error("dump.path", fmt::format("{}: the directory {} does not exist", outbase.string(), dir.string()), "output");
  if (!fs::is_directory(st))
    return make_error("dump.path", fmt::format("{}: {} is not a directory", outbase.string(), dir.string()), "output");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    return make_error("dump.path", fmt::format("{}: cannot write into {}: {}", outbase.string(), dir.string(), std::strerror(errno)),
                      "output");
  return {};
}

Result<void> check_inline_scene(const FrameRequest& request, const JobOptions& options) {
  if (request.source != Source::render || request.scene.kind != SceneRef::Kind::inline_json) return {};
  // The renderer's own two steps (shading/render_frame.cpp): strict parse, then validate.
  const shading::RenderRequest rq = render_request(request, options);
  auto scene = shading::parse_scene_json(*rq.scene_json, rq.load);
  Result<void> ok = scene ? shading::validate(*scene) : Result<void>(scene.error());
  if (ok) return {};
  Error e = ok.error();
  e.field = e.field.empty() ? "scene" : e.field.rfind("scene", 0) == 0 ? e.field : "scene." + e.field;
  if (e.message.rfind("scene", 0) != 0) e.message = "scene: " + e.message;
  return e;
}

Result<SequenceCheck> check_request(const FrameRequest& request, const JobOptions& options, const CheckOptions& check) {
  if (!check.outbase.empty())
    if (auto ok = check_output_base(check.outbase); !ok) return naming_setting(ok.error(), check.spelling);
  if (auto ok = check_inline_scene(request, options); !ok) return ok.error();
  if (!request.sequence) return SequenceCheck{};
  auto r = check_sequence(request, options);
  if (!r) return naming_setting(r.error(), check.spelling);
  return r;
}

Result<SequenceCheck> check_sequence(const FrameRequest& request, const JobOptions& options) {
  auto src = frame_source(request, options.files);
  if (!src) return src.error();
  const temporal::TemporalSettings ts = temporal_settings(request);
  if (auto ok = temporal::validate(ts); !ok) return ok.error();
  auto video = video_settings(request);
  if (!video) return video.error();
  SequenceCheck out;
  out.frames = src->total_from_scene ? 0 : src->total;
  out.inputs = src->inputs;
  EncodeInput input;
  if (request.source == Source::encode) input.path = src->inputs.front();
  auto first = FrameJob::create(request, options, input, std::vector<Output>{});
  if (!first) return first.error();
  out.target = (*first)->target();
  if (auto o = frame_outputs(request, out.target.mode, video->has_value()); !o) return o.error();
  if (*video) {
    video::StreamInfo stream;
    stream.target = out.target;
    stream.mastering = out.target.mastering();
    if (request.source == Source::render) {
      stream.width = static_cast<int>(request.integer("width"));
      stream.height = static_cast<int>(request.integer("height"));
    } else {
      // An encode's size is its EXRs': the first one's header, opened as its frame will be
      // (a frame whose header cannot be read here fails as that frame, with its own error).
      stream.width = stream.height = 64;  // an even stand-in
      const auto& path = src->inputs.front();
      if (auto fd = options.files.open(path); fd)
        if (auto head = io::read_prefix(fd->get(), path.string(), io::kExrHeaderPrefixBytes); head)
          if (auto size = io::exr_declared_size({reinterpret_cast<const std::uint8_t*>(head->data()), head->size()},
                                                path.filename().string());
              size) {
            stream.width = size->width;
            stream.height = size->height;
          }
    }
    if (auto ok = video::check_stream(**video, stream); !ok) return ok.error();
  }
  return out;
}

namespace {

// The shared body of run_sequence and analyse_sequence.
Result<SequenceResult> sequence_body(const FrameRequest& request, const fs::path& outbase, const SequenceOptions& options,
                                     shading::Renderer* renderer, std::vector<temporal::FrameDecision>* decided) {
  if (!decided && (outbase.empty() || !outbase.has_filename()))
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  auto src = frame_source(request, options.job.files);
  if (!src) return src.error();
  auto video = video_settings(request);
  if (!video) return video.error();
  const temporal::TemporalSettings ts = temporal_settings(request);
  if (auto ok = temporal::validate(ts); !ok) return ok.error();
  request.at("durable");
  (void)metadata_settings(request);

  const ShardSpec* shard = options.shard ? &*options.shard : nullptr;
  if (shard && src->total_from_scene && shard->track) {  // the plan's analysis counted them
    src->total = static_cast<int>(shard->track->size());
    src->total_from_scene = false;
  }
  if (src->total_from_scene) src->total = 1000000;  // until frame 0 tells the animation's length
  int first = 0, count = src->total;
  if (shard) {
    if (!shard->track || static_cast<int>(shard->track->size()) != src->total)
      return make_error("sequence.plan", fmt::format("the plan's track has {} frames, the sequence {}",
                                                     shard->track ? shard->track->size() : 0, src->total));
    if (shard->first_frame < 0 || shard->frame_count < 1 || shard->first_frame + shard->frame_count > src->total)
      return make_error("sequence.plan", fmt::format("frames {}..{} are outside the sequence's {}", shard->first_frame,
                                                     shard->first_frame + shard->frame_count - 1, src->total));
    first = shard->first_frame, count = shard->frame_count;
    std::error_code ec;
    fs::create_directories(shard->work_dir / "frames", ec);
    if (ec) return make_error("io.write", fmt::format("cannot make {}: {}", (shard->work_dir / "frames").string(), ec.message()));
  }

  std::unique_ptr<shading::Renderer> own_renderer;
  if (request.source == Source::render && !renderer) {
    const auto backend = shading::parse_backend(request.text("backend").empty() ? "auto" : request.text("backend"));
    auto made = shading::Renderer::create(backend.value_or(shading::Backend::automatic));
    if (!made) return made.error();
    own_renderer = std::move(*made);
    renderer = own_renderer.get();
  }

  // Live output (present.live): frames go to the display as the writer stage takes them.
  SequenceOptions opts = options;
  std::unique_ptr<display::SequencePresenter> presenter;
  if (request.boolean("present.live") && !decided && !shard) {
    display::SequenceOptions po;
    po.fps = src->fps;
    po.buffers = static_cast<int>(request.integer("present.buffers"));
    po.pacing = display::parse_pacing(request.text("present.pacing")).value_or(display::Pacing::every_frame);
    po.present.connector = request.text("present.connector");
    opts.on_frame = [&presenter, po, next = options.on_frame](const EncodedFrame& f, int index) -> Result<void> {
      if (!presenter) {
        auto p = display::open_sequence_presenter(po);
        if (!p) return p.error();
        presenter = std::move(*p);
      }
      if (auto ok = presenter->push(f); !ok) return ok.error();
      return next ? next(f, index) : Result<void>{};
    };
  } else {
    request.at("present.buffers"), request.at("present.pacing"), request.at("present.connector");
  }

  temporal::TemporalTone tone(ts);
  FrameLoop loop{request, opts, *src, renderer, &tone, shard ? shard->track : nullptr, decided};
  std::optional<SequenceSink> sink;
  BoundedQueue<FrameItem> queue(options.queue_depth);
  std::optional<Error> failure;
  std::mutex failure_mu;
  auto fail = [&](Error e) {
    std::lock_guard lock(failure_mu);
    if (!failure) failure = std::move(e);
    queue.close();
  };
  auto failed = [&] {
    std::lock_guard lock(failure_mu);
    return failure.has_value();
  };
  std::thread writer;
  struct Joiner {
    BoundedQueue<FrameItem>& q;
    std::thread& t;
    ~Joiner() {
      q.close();
      if (t.joinable()) t.join();
    }
  } joiner{queue, writer};
  auto start_sink = [&] {
    if (decided) return;
    sink.emplace(request, outbase, opts, *video, count);
    if (shard) sink->set_scenes_before(shard->scenes_before);
    writer = std::thread([&] {
      while (auto next = queue.pop()) {
        const std::string where = next->input.empty() ? fmt::format("frame {} (t = {:g} s)", next->index, next->time_s)
                                                      : fmt::format("frame {} ({})", next->index, next->input);
        if (auto ok = sink->consume(std::move(*next)); !ok) {
          Error e = ok.error();
          e.message = where + ": " + e.message;
          return fail(std::move(e));
        }
      }
    });
  };
  auto ran = run_frames(loop, first, count, std::nullopt, start_sink, queue, failed, [&](int total) {
    if (sink) sink->set_total(total);
  });
  if (!ran) fail(ran.error());
  queue.finish();
  if (writer.joinable()) writer.join();
  if (failed()) return *failure;
  if (decided) return SequenceResult{};
  if (presenter) {
    auto shown = presenter->finish();
    if (!shown) return shown.error();
    const auto& st = shown->stats;
    sink->set_present({{"connector", shown->setup.connector},
                       {"device", shown->setup.device},
                       {"frames_shown", st.frames_shown},
                       {"frames_dropped", st.frames_dropped},
                       {"frames_late", st.frames_late},
                       {"refresh_hz", st.refresh_hz},
                       {"measured_fps", st.measured_fps}});
  }
  return sink->finish(src->fps);
}

}  // namespace

Result<SequenceResult> run_sequence(const FrameRequest& request, const fs::path& outbase, const SequenceOptions& options,
                                    shading::Renderer* renderer) {
  return sequence_body(request, outbase, options, renderer, nullptr);
}

Result<std::vector<temporal::FrameDecision>> analyse_sequence(const FrameRequest& request, const SequenceOptions& options,
                                                              shading::Renderer* renderer) {
  if (options.shard) return make_error("internal", "the analysis covers the whole sequence, not a shard");
  std::vector<temporal::FrameDecision> decided;
  auto r = sequence_body(request, {}, options, renderer, &decided);
  if (!r) return r.error();
  return decided;
}

namespace {

// The per-frame dumps into place, each sidecar naming its files as a one-process run names
// them; `placed` gets every file made.
Result<void> place_frames(const std::vector<std::pair<fs::path, fs::path>>& moves, const fs::path& outbase,
                          std::vector<fs::path>& placed) {
  for (const auto& [from, to] : moves) {
    if (from.extension() == ".json") {
      auto text = read_text(from);
      if (!text) return text.error();
      nlohmann::json j = nlohmann::json::parse(*text, nullptr, false);
      if (!j.is_object() || !j["files"].is_object())
        return make_error("sequence.shard", fmt::format("{} is not a frame's sidecar", from.string()));
      // "frame.00012.raw" -> "OUTBASE-name.00012.raw"
      for (auto& [kind, name] : j["files"].items())
        if (name.is_string() && name.get<std::string>().rfind("frame.", 0) == 0)
          name = outbase.filename().string() + name.get<std::string>().substr(5);
      const std::string out = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
      if (auto ok = io::atomic_write(to, std::span(reinterpret_cast<const std::uint8_t*>(out.data()), out.size())); !ok)
        return ok.error();
      placed.push_back(to);
      continue;
    }
    // A hard link where the work dir and OUTBASE share a file system (no copy), else a copy:
    // the work dir stays whole, so the merge can run again.
    std::error_code ec;
    fs::remove(to, ec);
    fs::create_hard_link(from, to, ec);
    if (ec) {
      ec.clear();
      fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
      if (ec) return make_error("io.write", fmt::format("cannot copy {} to {}: {}", from.string(), to.string(), ec.message()));
    }
    placed.push_back(to);
  }
  return {};
}

}  // namespace

Result<SequenceResult> merge_sequence_shards(const FrameRequest& request, const std::vector<fs::path>& shard_stats,
                                             const std::string& fingerprint, const fs::path& outbase) {
  if (outbase.empty() || !outbase.has_filename())
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  auto src = frame_source(request);
  if (!src) return src.error();
  auto settings_of_video = video_settings(request);
  if (!settings_of_video) return settings_of_video.error();
  const std::optional<video::VideoSettings>& vs = *settings_of_video;
  SequenceSummary sum;
  std::optional<video::SequenceMetadata> metadata;
  std::vector<fs::path> segments;
  std::vector<std::pair<fs::path, fs::path>> moves;  // per-frame dumps: work dir -> OUTBASE.NNNNN.EXT
  video::StreamInfo stream_info{};
  int next_frame = 0;
  for (std::size_t i = 0; i < shard_stats.size(); ++i) {
    const std::string shard = fmt::format("shard {} of {}", i, shard_stats.size());
    auto text = read_text(shard_stats[i]);
    if (!text) return make_error("sequence.shard", fmt::format("{}: {}", shard, text.error().message));
    const nlohmann::json st = nlohmann::json::parse(*text, nullptr, false);
    if (!st.is_object() || st.value("format", "") != "hdrd-sequence-shard")
      return make_error("sequence.shard", fmt::format("{}: {} is not a shard's statistics", shard, shard_stats[i].string()));
    if (st.value("fingerprint", "") != fingerprint)
      return make_error("sequence.shard", fmt::format("{} was made from another plan (fingerprint {}, the plan's {})", shard,
                                                      st.value("fingerprint", "none"), fingerprint));
    if (st.value("first_frame", -1) != next_frame)
      return make_error("sequence.shard", fmt::format("{} starts at frame {}, expected {}", shard, st.value("first_frame", -1),
                                                      next_frame));
    const auto& frames = st["frames"];
    const auto& lights = st["lights"];
    if (!frames.is_array() || !lights.is_array() || frames.size() != lights.size() ||
        static_cast<int>(frames.size()) != st.value("frame_count", -1) || frames.empty())
      return make_error("sequence.shard", fmt::format("{}: its frame list is inconsistent", shard));
    if (!metadata) {
      sum.first_sidecar = st["first_sidecar"];
      sum.frame_kinds = st["frame_kinds"].get<std::vector<std::string>>();
      // The signal the frames were encoded for: the request's display, resolved as the
      // shards resolved it (no render; the frames' own size from the first shard).
      EncodeInput input;
      if (request.source == Source::encode) input.path = src->inputs.front();
      auto job = FrameJob::create(request, {}, input, std::vector<Output>{});
      if (!job) return job.error();
      const DisplayTarget target = (*job)->target();
      metadata.emplace(target, target.mastering(), metadata_settings(request));
      stream_info = {sum.first_sidecar.value("width", 0), sum.first_sidecar.value("height", 0), target,
                     target.mastering()};
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
      auto light = light_from_json(lights[k]);
      if (!light) return light.error();
      if (auto ok = metadata->add(*light, frames[k].value("scene_start", false)); !ok) return ok.error();
      sum.frames.push_back(frames[k]);
      const int index = next_frame + static_cast<int>(k);
      for (const auto& kind : sum.frame_kinds) {
        const std::string ext = kind == "sidecar" ? std::string(kSidecarSuffix) : std::string(find_output(kind)->suffix);
        const fs::path from = shard_stats[i].parent_path() / "frames" / fmt::format("frame.{:05d}{}", index, ext);
        if (!fs::exists(from)) return make_error("sequence.shard", fmt::format("{}: {} is missing", shard, from.string()));
        moves.emplace_back(from, fs::path(frame_base(outbase, index) + ext));
      }
    }
    for (const auto& w : st["warnings"])
      if (std::find(sum.warnings.begin(), sum.warnings.end(), w.get<std::string>()) == sum.warnings.end())
        sum.warnings.push_back(w.get<std::string>());
    if (vs) {
      if (!st["segment"].is_string()) return make_error("sequence.shard", fmt::format("{} has no video segment", shard));
      segments.push_back(shard_stats[i].parent_path() / st["segment"].get<std::string>());
    }
    next_frame += static_cast<int>(frames.size());
  }
  if (next_frame != src->total)
    return make_error("sequence.shard", fmt::format("the shards hold {} frames, the sequence {}", next_frame, src->total));
  metadata->finish();
  std::optional<video::VideoResult> result_video;
  if (vs) {
    auto v = video::SequenceWriter::join_segments(outbase, *vs, stream_info, segments, *metadata);
    if (!v) return v.error();
    result_video = std::move(*v);
  }
  // Everything placed at OUTBASE goes again if a later step fails: all or nothing.
  std::vector<fs::path> placed;
  if (result_video) placed.push_back(result_video->path);
  struct Undo {
    std::vector<fs::path>& files;
    bool done = false;
    ~Undo() {
      std::error_code ec;
      if (!done)
        for (const auto& f : files) fs::remove(f, ec);
    }
  } undo{placed};
  if (auto ok = place_frames(moves, outbase, placed); !ok) return ok.error();
  auto out = write_sequence_outputs(request, outbase, src->fps, sum, *metadata, result_video);
  if (out) undo.done = true;
  return out;
}

}  // namespace hdrd::job

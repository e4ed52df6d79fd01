#include "job/sequence.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fstream>
#include <mutex>
#include <regex>
#include <thread>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/temporal.hpp"
#include "encode/video/encoder_config.hpp"
#include "encode/video/sequence_metadata.hpp"
#include "encode/video/writer.hpp"
#include "shading/renderer.hpp"

namespace hdrd::job {
namespace fs = std::filesystem;

// ---- the frames of an EXR sequence -------------------------------------------------------

namespace {

Error sequence_error(std::string message) { return make_error("input.sequence", std::move(message), "images"); }

// "shot.%04d.exr" -> prefix "shot.", width 4, suffix ".exr"; nullopt when the name holds
// no single %d / %0Nd conversion.
struct FramePattern {
  std::string prefix, suffix;
  int width = 0;
};
std::optional<FramePattern> parse_frame_pattern(const std::string& name) {
  static const std::regex conversion(R"(^(.*?)%(0?([1-9]))?d(.*)$)");
  std::smatch m;
  if (!std::regex_match(name, m, conversion)) return std::nullopt;
  FramePattern p{m[1].str(), m[4].str(), m[3].matched ? std::stoi(m[3].str()) : 0};
  if (p.prefix.find('%') != std::string::npos || p.suffix.find('%') != std::string::npos) return std::nullopt;
  return p;
}

Result<std::vector<fs::path>> pattern_files(const fs::path& spec, const FramePattern& p) {
  const fs::path dir = spec.has_parent_path() ? spec.parent_path() : fs::path(".");
  std::error_code ec;
  std::vector<std::pair<long long, fs::path>> found;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= p.prefix.size() + p.suffix.size() || n.compare(0, p.prefix.size(), p.prefix) != 0 ||
        n.compare(n.size() - p.suffix.size(), p.suffix.size(), p.suffix) != 0)
      continue;
    const std::string digits = n.substr(p.prefix.size(), n.size() - p.prefix.size() - p.suffix.size());
    if (digits.size() > 12 || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
      continue;
    if (p.width > 0 && digits.size() < static_cast<std::size_t>(p.width)) continue;  // %04d writes at least 4
    if (p.width > 0 && digits.size() > static_cast<std::size_t>(p.width) && digits[0] == '0') continue;
    if (p.width == 0 && digits.size() > 1 && digits[0] == '0') continue;  // %d writes no leading zeros
    found.emplace_back(std::stoll(digits), it->path());
  }
  if (ec) return sequence_error(fmt::format("{}: cannot read the directory {}: {}", spec.string(), dir.string(), ec.message()));
  if (found.empty()) return sequence_error(fmt::format("{}: no file matches the pattern", spec.string()));
  std::sort(found.begin(), found.end());
  std::vector<fs::path> files;
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (i > 0 && found[i].first == found[i - 1].first)
      return sequence_error(fmt::format("{}: frame {} exists twice", spec.string(), found[i].first));
    if (i > 0 && found[i].first != found[i - 1].first + 1)
      return sequence_error(fmt::format("{}: frame {} is missing (frames {}..{} exist, then {})", spec.string(),
                                        found[i - 1].first + 1, found.front().first, found[i - 1].first,
                                        found[i].first));
    files.push_back(found[i].second);
  }
  return files;
}

Result<std::vector<fs::path>> directory_files(const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::string ext = it->path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".exr" && it->is_regular_file(ec)) files.push_back(it->path());
  }
  if (ec) return sequence_error(fmt::format("{}: cannot read the directory: {}", dir.string(), ec.message()));
  if (files.empty()) return sequence_error(fmt::format("{}: the directory holds no .exr file", dir.string()));
  std::sort(files.begin(), files.end());
  return files;
}

Result<std::vector<fs::path>> list_files(const fs::path& list) {
  std::ifstream in(list);
  if (!in) return sequence_error(fmt::format("{}: cannot open the list file", list.string()));
  std::vector<fs::path> files;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.size() > 4096) return sequence_error(fmt::format("{}:{}: a line longer than 4096 bytes", list.string(), number));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t");
    fs::path p = line.substr(first, last - first + 1);
    if (p.is_relative()) p = list.parent_path() / p;
    files.push_back(std::move(p));
    if (files.size() > 1000000) return sequence_error(fmt::format("{}: more than 1000000 frames", list.string()));
  }
  if (files.empty()) return sequence_error(fmt::format("{}: the list names no file", list.string()));
  return files;
}

bool is_list_file(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".txt" || ext == ".lst" || ext == ".list";
}

}  // namespace

bool names_a_sequence(const fs::path& spec) {
  std::error_code ec;
  return parse_frame_pattern(spec.filename().string()).has_value() || fs::is_directory(spec, ec) || is_list_file(spec);
}

Result<std::vector<fs::path>> exr_sequence_files(const fs::path& spec) {
  if (spec.empty()) return sequence_error("a sequence of EXR frames is needed (a pattern, a directory or a list file)");
  if (const auto p = parse_frame_pattern(spec.filename().string())) return pattern_files(spec, *p);
  std::error_code ec;
  if (fs::is_directory(spec, ec)) return directory_files(spec);
  if (is_list_file(spec)) return list_files(spec);
  return sequence_error(fmt::format("{}: not a frame pattern (%04d), a directory or a list file (.txt)", spec.string()));
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

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The frame rate as the container's rational: NTSC rates exactly (24000/1001, ...).
std::pair<int, int> rational_fps(double fps) {
  for (int base : {24, 30, 48, 60, 120, 240})
    if (std::abs(fps - base * 1000.0 / 1001.0) < 5e-4) return {base * 1000, 1001};
  if (std::abs(fps - std::round(fps)) < 1e-9) return {static_cast<int>(std::round(fps)), 1};
  return {static_cast<int>(std::round(fps * 1000)), 1000};
}

Result<video::VideoSettings> video_settings(const FrameRequest& r, double fps) {
  video::VideoSettings v;
  v.codec = video::parse_codec(r.text("video.codec")).value_or(video::Codec::hevc);
  v.container = video::parse_container(r.text("video.container")).value_or(video::Container::mp4);
  v.crf = r.optional_number("video.crf");
  v.preset = r.text("video.preset");
  v.lossless = r.boolean("video.lossless");
  v.range = parse_range(r.text("video.range")).value_or(Range::narrow);
  std::tie(v.fps_num, v.fps_den) = rational_fps(fps);
  v.keyframe_interval_s = r.number("video.keyframe_interval_s");
  v.threads = static_cast<int>(r.integer("video.threads"));
  v.av1_encoder = r.text("video.av1_encoder");
  v.dynamic_metadata = r.boolean("video.dynamic_metadata");
  if (auto ok = video::validate(v); !ok) return ok.error();
  return v;
}

temporal::TemporalSettings temporal_settings(const FrameRequest& r) {
  exposure::Settings e;
  e.adaptation_time_s = r.number("exposure.adaptation_time_s");
  e.adaptation_brighten_time_s = r.optional_number("exposure.adaptation_brighten_time_s");
  e.adaptation_darken_time_s = r.optional_number("exposure.adaptation_darken_time_s");
  temporal::TemporalSettings t;
  t.adaptation = temporal::adaptation_settings(e);
  t.scene_cut.threshold_stops = r.number("sequence.cut_threshold_stops");
  t.detect_cuts = r.boolean("sequence.detect_cuts");
  t.peak.percentile = r.number("tone.peak_percentile");
  t.peak.rise_time_s = r.number("tone.peak_rise_time_s");
  t.peak.fall_time_s = r.number("tone.peak_fall_time_s");
  return t;
}

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
  std::string input;                       // an encode's EXR
  FrameResult result;
};

std::string frame_base(const fs::path& outbase, int index) { return fmt::format("{}.{:05d}", outbase.string(), index); }

// The writer stage: per-frame dumps, the video encoder, the metadata, live output.
class SequenceSink {
 public:
  SequenceSink(const FrameRequest& r, const fs::path& outbase, const SequenceOptions& options,
               std::optional<video::VideoSettings> video, int total)
      : request_(r), outbase_(outbase), options_(options), video_settings_(std::move(video)), total_(total) {}
  ~SequenceSink() {
    if (!finished_) remove_written();
  }

  Result<void> consume(FrameItem item) {
    const auto t0 = Clock::now();
    const EncodedFrame& f = item.result.frame;
    if (!metadata_) {
      metadata_.emplace(f.target, f.mastering, metadata_settings());
      first_sidecar_ = io::sidecar_json(f, {});
      target_ = f.target;
      if (video_settings_) {
        auto w = video::SequenceWriter::open(outbase_, *video_settings_, {f.width, f.height, f.target, f.mastering});
        if (!w) return w.error();
        writer_ = std::move(*w);
      }
    }
    if (!item.result.files.empty()) {
      auto written = write_outputs(item.result, frame_base(outbase_, item.index));
      if (!written) return written.error();
      for (const auto& [kind, path] : *written) {
        written_.push_back(path);
        if (item.index == 0) frame_kinds_.push_back(kind);
      }
    }
    timings_["dumps"] = timings_.value("dumps", 0.0) + seconds_since(t0) * 1e3;
    const bool start = item.decision.scene_start;
    const auto t1 = Clock::now();
    if (auto ok = metadata_->add(f, start); !ok) return ok.error();
    timings_["metadata"] = timings_.value("metadata", 0.0) + seconds_since(t1) * 1e3;
    if (writer_) {
      const auto t2 = Clock::now();
      if (auto ok = writer_->write(f, {.keyframe = start}); !ok) return ok.error();
      timings_["video"] = timings_.value("video", 0.0) + seconds_since(t2) * 1e3;
    }
    if (options_.on_frame)
      if (auto ok = options_.on_frame(f, item.index); !ok) return ok.error();
    scenes_ += start ? 1 : 0;
    nlohmann::json entry = {{"index", item.index},
                            {"time_s", item.time_s},
                            {"scene", scenes_ - 1},
                            {"scene_start", start},
                            {"exposure_scale", f.settings.contains("exposure") ? f.settings["exposure"].value("scale", 0.0)
                                                                              : item.decision.exposure_scale},
                            {"metered_exposure_scale", item.decision.own_scale},
                            {"cut_distance_stops", item.decision.cut_distance_stops},
                            {"max_cll_nits", f.content_light.max_cll_nits},
                            {"frame_average_nits", f.content_light.max_fall_nits}};
    if (item.source_peak_nits) entry["source_peak_nits"] = *item.source_peak_nits;
    if (!item.input.empty()) entry["input"] = item.input;
    frames_.push_back(std::move(entry));
    for (const auto& w : item.result.warnings)
      if (std::find(warnings_.begin(), warnings_.end(), w) == warnings_.end()) warnings_.push_back(w);
    for (const auto& [stage, ms] : item.result.timings_ms.items())
      if (ms.is_number()) timings_[stage] = timings_.value(stage, 0.0) + ms.get<double>();
    if (options_.progress) {
      SequenceProgress p;
      p.frames_done = static_cast<int>(frames_.size());
      p.frames_total = total_;
      p.elapsed_s = seconds_since(start_);
      p.fps = p.elapsed_s > 0 ? p.frames_done / p.elapsed_s : 0;
      p.eta_s = p.fps > 0 ? (total_ - p.frames_done) / p.fps : 0;
      options_.progress(p);
    }
    return {};
  }

  Result<SequenceResult> finish(double fps) {
    if (!metadata_) return make_error("internal", "a sequence finished without frames");
    metadata_->finish();
    SequenceResult out;
    nlohmann::json j = first_sidecar_;
    j["format"] = "hdrd-sequence";
    j["format_version"] = 1;
    j["fps"] = fps;
    j["frame_count"] = frames_.size();
    j["duration_s"] = frames_.size() / fps;
    j["frames"] = frames_;
    nlohmann::json scenes = nlohmann::json::array();
    for (const auto& s : metadata_->scenes()) scenes.push_back({{"first_frame", s.first_frame}, {"last_frame", s.last_frame}});
    j["scenes"] = scenes;
    // CTA-861.3 over the whole sequence: the largest pixel and the largest frame average.
    const ContentLightLevel measured = metadata_->content_light();
    const CarriedLightLevel carried =
        target_.is_hdr() ? carried_light_level(measured, metadata_->mastering()) : CarriedLightLevel{};
    j["content_light_level"] = {{"max_cll_nits", carried.max_cll_nits},
                                {"max_fall_nits", carried.max_fall_nits},
                                {"max_cll_nits_measured", measured.max_cll_nits},
                                {"max_fall_nits_measured", measured.max_fall_nits}};
    j.erase("settings");
    j["settings"] = {{"request", request_.canonical()}};
    j["warnings"] = warnings_;
    nlohmann::json files = nlohmann::json::object();
    const std::string stem = outbase_.filename().string();
    for (const auto& kind : frame_kinds_) {
      const std::string ext = kind == "sidecar" ? ".json" : std::string(output_info(find_output(kind)->id).suffix);
      files["frames"][kind] = fmt::format("{}.%05d{}", stem, ext);
      out.files["frames." + kind] = fmt::format("{}.%05d{}", outbase_.string(), ext);
    }
    std::vector<std::string> texts;
    std::vector<fs::path> paths;
    if (metadata_->has_dynamic_metadata()) {
      paths.push_back(outbase_.string() + ".hdr10plus.json");
      texts.push_back(metadata_->hdr10plus_json().dump(2) + "\n");
      files["hdr10plus"] = paths.back().filename().string();
      out.files["hdr10plus"] = paths.back().string();
      paths.push_back(outbase_.string() + ".dovi.json");
      texts.push_back(metadata_->dovi_json().dump(2) + "\n");
      files["dovi"] = paths.back().filename().string();
      out.files["dovi"] = paths.back().string();
    }
    if (writer_) {
      const auto t0 = Clock::now();
      auto v = writer_->finish(&*metadata_);
      if (!v) return v.error();
      timings_["video"] = timings_.value("video", 0.0) + seconds_since(t0) * 1e3;
      written_.push_back(v->path.string());
      nlohmann::json vj = v->to_json();
      vj["file"] = v->path.filename().string();
      j["video"] = vj;
      files["video"] = v->path.filename().string();
      out.files["video"] = v->path.string();
    }
    const fs::path sidecar = outbase_.string() + ".json";
    files["sidecar"] = sidecar.filename().string();
    j["files"] = files;
    j["timings_ms"] = timings_;
    paths.push_back(sidecar);
    texts.push_back(j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
    std::vector<io::FileToWrite> writes;
    for (std::size_t i = 0; i < paths.size(); ++i)
      writes.push_back({paths[i], std::span(reinterpret_cast<const std::uint8_t*>(texts[i].data()), texts[i].size())});
    if (auto ok = io::write_all_or_nothing(writes, {.durable = request_.boolean("durable")}); !ok) return ok.error();
    out.files["sidecar"] = sidecar.string();
    out.sidecar = std::move(j);
    out.frames = static_cast<int>(frames_.size());
    out.warnings = warnings_;
    out.timings_ms = timings_;
    finished_ = true;
    return out;
  }

 private:
  video::SequenceMetadataSettings metadata_settings() const {
    video::SequenceMetadataSettings s;
    s.granularity = video::parse_granularity(request_.text("metadata.granularity")).value_or(s.granularity);
    s.hdr10plus_target_nits = request_.optional_number("metadata.hdr10plus_target_nits");
    return s;
  }
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
  DisplayTarget target_;
  nlohmann::json first_sidecar_;
  nlohmann::json frames_ = nlohmann::json::array();
  std::vector<std::string> frame_kinds_, written_, warnings_;
  nlohmann::json timings_ = nlohmann::json::object();
  int scenes_ = 0;
  bool finished_ = false;
};

// The outputs of each frame: the request's formats; without formats, the mode's default
// dump when there is no video, else none (the video is the sequence's output).
Result<std::vector<Output>> frame_outputs(const FrameRequest& r, Mode mode, bool video) {
  if (r.has("formats")) return outputs_from_names(r.list("formats"), r.source, mode);
  if (video) return std::vector<Output>{};
  return default_outputs(r.source, mode);
}

// The frame count and an encode's EXR files: every input unless `frames` asks for fewer.
Result<std::pair<int, std::vector<fs::path>>> sequence_frames(const FrameRequest& request) {
  std::vector<fs::path> inputs;
  int total = request.is_null("frames") ? 1 : static_cast<int>(request.integer("frames"));
  if (request.source == Source::encode) {
    auto files = exr_sequence_files(request.text("images"));
    if (!files) return files.error();
    if (!request.is_null("frames") && total > static_cast<int>(files->size()))
      return make_error("request.value",
                        fmt::format("frames: {} asked, {} has {}", total, request.text("images"), files->size()),
                        "frames");
    if (request.is_null("frames")) total = static_cast<int>(files->size());
    files->resize(total);
    inputs = std::move(*files);
  }
  return std::pair{total, std::move(inputs)};
}

}  // namespace

Result<SequencePlan> plan_sequence(const FrameRequest& request, const JobOptions& options) {
  if (request.source == Source::pattern) return make_error("request.value", "patterns have no sequence form", "frames");
  const double fps = request.number("fps");
  const temporal::TemporalSettings ts = temporal_settings(request);
  if (auto ok = temporal::validate(ts); !ok) return ok.error();
  auto frames = sequence_frames(request);
  if (!frames) return frames.error();
  SequencePlan plan;
  plan.frames = frames->first;
  plan.inputs = std::move(frames->second);
  EncodeInput input;
  if (request.source == Source::encode) input.path = plan.inputs.front();
  auto first = FrameJob::create(request, options, input);
  if (!first) return first.error();
  plan.target = (*first)->target();
  if (auto o = frame_outputs(request, plan.target.mode, !request.is_null("video.codec")); !o) return o.error();
  if (!request.is_null("video.codec")) {
    auto v = video_settings(request, fps);
    if (!v) return v.error();
    video::StreamInfo stream;
    stream.target = plan.target;
    // An encode's size is the EXRs' (known at its first frame): an even stand-in here.
    stream.width = request.source == Source::render ? static_cast<int>(request.integer("width")) : 64;
    stream.height = request.source == Source::render ? static_cast<int>(request.integer("height")) : 64;
    if (auto c = video::encoder_config(*v, stream); !c) return c.error();
  }
  return plan;
}

Result<SequenceResult> run_sequence(const FrameRequest& request, const fs::path& outbase, const SequenceOptions& options,
                                    shading::Renderer* renderer) {
  if (request.source == Source::pattern) return make_error("request.value", "patterns have no sequence form", "frames");
  if (outbase.empty() || !outbase.has_filename())
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  const double fps = request.number("fps");
  const double dt = 1.0 / fps;
  std::optional<video::VideoSettings> video;
  if (!request.is_null("video.codec")) {
    auto v = video_settings(request, fps);
    if (!v) return v.error();
    video = *v;
  } else {
    // Read so that the "every setting is used" check sees them: they only matter with a codec.
    for (const auto& s : settings())
      if (s.path.rfind("video.", 0) == 0) request.at(s.path);
  }
  const temporal::TemporalSettings ts = temporal_settings(request);
  if (auto ok = temporal::validate(ts); !ok) return ok.error();

  auto frames = sequence_frames(request);
  if (!frames) return frames.error();
  const int total = frames->first;
  const std::vector<fs::path> inputs = std::move(frames->second);
  const double start_s = request.source == Source::render ? request.number("start_s") : 0.0;

  std::unique_ptr<shading::Renderer> own_renderer;
  if (request.source == Source::render && !renderer) {
    const auto backend = shading::parse_backend(request.text("backend").empty() ? "auto" : request.text("backend"));
    auto made = shading::Renderer::create(backend.value_or(shading::Backend::automatic));
    if (!made) return made.error();
    own_renderer = std::move(*made);
    renderer = own_renderer.get();
  }

  temporal::TemporalTone tone(ts);
  const bool dynamic_peak = request.boolean("tone.dynamic_peak");
  const nlohmann::json& given_params = request.at("tone.params");
  std::optional<std::vector<Output>> outputs;
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
  auto join_writer = [&] {
    if (writer.joinable()) writer.join();
  };
  struct Joiner {
    std::function<void()> f;
    ~Joiner() { f(); }
  } joiner{[&] {
    queue.close();
    join_writer();
  }};

  for (int i = 0; i < total && !failed(); ++i) {
    if (options.job.should_stop && options.job.should_stop()) {
      fail(make_error("request.cancelled", "cancelled"));
      break;
    }
    FrameItem item;
    item.index = i;
    item.time_s = start_s + i * dt;
    JobOptions jo = options.job;
    jo.time_s = item.time_s;
    jo.temporal = [&](const SceneInput& in, PreparedPipeline& p) -> Result<void> {
      const auto lum = scene_luminance_nits(in, p.unit_nits);
      auto d = tone.next(lum, p.settings.exposure, p.settings.target.paper_white_nits, dt);
      if (!d) return d.error();
      // Manual and camera exposure are what the request (or the scene's keyframes) says,
      // frame by frame: exactly each frame's single-frame encode. Metered modes adapt.
      const auto mode = p.settings.exposure.mode;
      if (mode != exposure::Mode::manual && mode != exposure::Mode::camera) set_exposure_scale(p, d->exposure_scale);
      const std::string_view param = p.curve_info ? source_peak_param(*p.curve_info) : std::string_view();
      if (dynamic_peak && !param.empty() && !given_params.contains(std::string(param))) {
        if (auto ok = set_source_peak(p, d->source_peak); !ok) return ok.error();
        item.source_peak_nits = d->source_peak * p.settings.target.paper_white_nits;
      }
      item.decision = *d;
      return {};
    };
    EncodeInput input;
    if (request.source == Source::encode) {
      input.path = inputs[i];
      item.input = inputs[i].filename().string();
    }
    FrameRequest frame_request = request;
    auto job = FrameJob::create(std::move(frame_request), std::move(jo), input, outputs);
    if (!job) {
      fail(job.error());
      break;
    }
    if (!outputs) {
      auto o = frame_outputs(request, (*job)->target().mode, video.has_value());
      if (!o) {
        fail(o.error());
        break;
      }
      outputs = *o;
      if (auto ok = (*job)->set_outputs(*outputs); !ok) {
        fail(ok.error());
        break;
      }
      sink.emplace(request, outbase, options, video, total);
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
    }
    auto result = run_frame_job(**job, renderer);
    if (!result) {
      Error e = result.error();
      e.message = (request.source == Source::encode ? fmt::format("frame {} ({}): ", i, item.input)
                                                     : fmt::format("frame {} (t = {:g} s): ", i, item.time_s)) +
                  e.message;
      fail(std::move(e));
      break;
    }
    item.result = std::move(*result);
    if (!queue.push(std::move(item))) break;
  }
  queue.finish();
  join_writer();
  if (failed()) return *failure;
  auto out = sink->finish(fps);
  if (!out) return out.error();
  return out;
}

}  // namespace hdrd::job

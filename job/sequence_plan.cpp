#include "job/sequence_plan.hpp"

#include <algorithm>
#include <fstream>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "shading/scene_loader.hpp"

namespace hdrd::job {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

Error plan_error(const fs::path& plan, std::string what) {
  return make_error("sequence.plan", fmt::format("plan {}: {}", plan.string(), what), "plan");
}

json pointer_of(std::string_view path) {
  std::string p(path);
  std::replace(p.begin(), p.end(), '.', '/');
  return "/" + p;
}

// Every path setting (and a scene file) made absolute: the shards may run elsewhere, from
// another working directory, on the same shared file system.
json absolute_paths(json request) {
  for (const auto& s : settings()) {
    if (s.type != Type::path) continue;
    const json::json_pointer ptr(pointer_of(s.path).get<std::string>());
    if (request.contains(ptr) && request[ptr].is_string() && !request[ptr].get<std::string>().empty())
      request[ptr] = fs::absolute(request[ptr].get<std::string>()).lexically_normal().string();
  }
  if (auto it = request.find("scene"); it != request.end() && it->is_string() && !shading::is_builtin_scene(it->get<std::string>()))
    *it = fs::absolute(it->get<std::string>()).lexically_normal().string();
  return request;
}

ParseContext plan_context(Source source) {
  ParseContext ctx;
  ctx.source = source;
  ctx.spelling = Spelling::json;
  ctx.reach = Reach::cli;
  ctx.sequence = true;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<fs::path> { return fs::path(p); };
  return ctx;
}

json decision_json(const temporal::FrameDecision& d) {
  return {{"scene_start", d.scene_start},
          {"cut_distance_stops", d.cut_distance_stops},
          {"own_scale", d.own_scale},
          {"exposure_scale", d.exposure_scale},
          {"source_peak", d.source_peak},
          {"source_average", d.source_average}};
}

Result<temporal::FrameDecision> decision_from_json(const json& j) {
  temporal::FrameDecision d;
  if (!j.is_object() || !j.value("scene_start", json()).is_boolean()) return make_error("sequence.plan", "a track entry is malformed");
  d.scene_start = j["scene_start"].get<bool>();
  for (auto [name, field] : {std::pair{"cut_distance_stops", &d.cut_distance_stops}, std::pair{"own_scale", &d.own_scale},
                             std::pair{"exposure_scale", &d.exposure_scale}, std::pair{"source_peak", &d.source_peak}}) {
    const auto it = j.find(name);
    if (it == j.end() || !it->is_number() || !std::isfinite(it->get<double>()))
      return make_error("sequence.plan", fmt::format("a track entry's {} is not a finite number", name));
    *field = it->get<double>();
  }
  // Plans written before the scene average was tracked have none: 0, "not measured".
  if (const auto it = j.find("source_average"); it != j.end()) {
    if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < 0)
      return make_error("sequence.plan", "a track entry's source_average is not a finite number >= 0");
    d.source_average = it->get<double>();
  }
  if (!(d.exposure_scale > 0) || !(d.own_scale > 0) || !(d.source_peak > 0))
    return make_error("sequence.plan", "a track entry's scales must be positive");
  return d;
}

// FNV-1a 64 of the canonical text of what decides the frames and where they are written:
// the work dir as written (a relative one moves with the plan's folder) and the source with
// them, so that an edited work_dir cannot send the shards elsewhere (issue 28.11).
std::string fingerprint_of(const SequencePlan& plan, const json& track, const json& ranges) {
  const std::string text = json{{"request", plan.request},
                                {"track", track},
                                {"ranges", ranges},
                                {"work_dir", plan.work_dir.string()},
                                {"source", to_string(plan.source)}}
                               .dump();
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return fmt::format("{:016x}", h);
}

json ranges_json(const std::vector<std::pair<int, int>>& ranges) {
  json out = json::array();
  for (std::size_t i = 0; i < ranges.size(); ++i)
    out.push_back({{"shard", i}, {"first_frame", ranges[i].first}, {"frame_count", ranges[i].second}});
  return out;
}

json track_json(const std::vector<temporal::FrameDecision>& track) {
  json out = json::array();
  for (const auto& d : track) out.push_back(decision_json(d));
  return out;
}

}  // namespace

fs::path SequencePlan::resolved_work_dir() const {
  return work_dir.is_absolute() ? work_dir : (plan_path.has_parent_path() ? plan_path.parent_path() : fs::path(".")) / work_dir;
}

json SequencePlan::to_json() const {
  // The header fields the engines read come first (deploy/lib/plan.sh, daemon/cluster/slurm.cpp).
  json j = json::object();
  j["format"] = "hdrd-sequence-plan";
  j["format_version"] = 1;
  j["shards"] = shards;
  j["frames"] = frames;
  j["work_dir"] = work_dir.string();
  j["outbase"] = nullptr;
  j["source"] = to_string(source);
  j["fingerprint"] = fingerprint;
  j["ranges"] = ranges_json(ranges);
  j["request"] = request;
  j["track"] = track_json(track);
  return j;
}

Result<SequencePlan> make_sequence_plan(const json& request, Source source, int shards, const fs::path& plan_path,
                                        const SequenceOptions& options) {
  if (plan_path.empty() || !plan_path.has_filename())
    return make_error("sequence.plan", "-o PLAN.json is required", "output");
  if (shards < 1 || shards > 1000000)
    return make_error("request.value", fmt::format("shards: {} is outside [1, 1000000]", shards), "shards");
  SequencePlan plan;
  plan.shards = shards;
  plan.source = source;
  plan.plan_path = plan_path;
  plan.work_dir = fs::absolute(plan_path).lexically_normal().string() + ".d";  // beside the plan, as every node sees it
  plan.request = absolute_paths(request);
  auto parsed = parse_request_json(plan.request, plan_context(source));
  if (!parsed) return parsed.error();
  if (auto ok = check_request(*parsed, options.job); !ok) return ok.error();  // before the analysis renders a frame
  auto track = analyse_sequence(*parsed, options);
  if (!track) return track.error();
  plan.track = std::move(*track);
  plan.frames = static_cast<int>(plan.track.size());
  if (shards > plan.frames)
    return make_error("request.value", fmt::format("shards: {} shards for {} frames", shards, plan.frames), "shards");
  for (int i = 0; i < shards; ++i) {
    const int first = static_cast<int>(static_cast<long long>(i) * plan.frames / shards);
    const int end = static_cast<int>(static_cast<long long>(i + 1) * plan.frames / shards);
    plan.ranges.emplace_back(first, end - first);
  }
  plan.fingerprint = fingerprint_of(plan, track_json(plan.track), ranges_json(plan.ranges));
  return plan;
}

Result<void> write_sequence_plan(const SequencePlan& plan) {
  std::error_code ec;
  fs::create_directories(plan.resolved_work_dir(), ec);
  if (ec) return make_error("io.write", fmt::format("cannot make the work dir {}: {}", plan.resolved_work_dir().string(), ec.message()));
  const std::string text = plan.to_json().dump(1) + "\n";
  return io::atomic_write(plan.plan_path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()),
                          {.durable = true});
}

Result<SequencePlan> read_sequence_plan(const fs::path& plan_path) {
  // Opened as the file model opens a file given as is (encode/io/beneath.hpp): never
  // waiting on a FIFO, refusing what is not a regular file.
  auto text = io::InputFiles{}.read(plan_path, std::size_t{1} << 30);
  if (!text && text.error().code == "file.too_large") return plan_error(plan_path, "larger than 1 GiB");
  if (!text) return plan_error(plan_path, "cannot read it: " + text.error().message);
  const json j = json::parse(*text, nullptr, false);
  if (!j.is_object() || j.value("format", "") != "hdrd-sequence-plan")
    return plan_error(plan_path, "not an hdrd sequence plan (format hdrd-sequence-plan)");
  if (j.value("format_version", 0) != 1) return plan_error(plan_path, "format_version is not 1");
  SequencePlan plan;
  plan.plan_path = plan_path;
  auto integer = [&](const char* name, int min, int max, int& out) -> Result<void> {
    const auto it = j.find(name);
    if (it == j.end() || !it->is_number_integer() || it->get<long long>() < min || it->get<long long>() > max)
      return plan_error(plan_path, fmt::format("{} is not an integer in [{}, {}]", name, min, max));
    out = it->get<int>();
    return {};
  };
  if (auto ok = integer("shards", 1, 1000000, plan.shards); !ok) return ok.error();
  if (auto ok = integer("frames", 1, 1000000, plan.frames); !ok) return ok.error();
  if (!j.value("work_dir", json()).is_string() || j["work_dir"].get<std::string>().empty())
    return plan_error(plan_path, "work_dir is not a path");
  plan.work_dir = j["work_dir"].get<std::string>();
  const std::string source = j.value("source", "");
  if (source == "render") plan.source = Source::render;
  else if (source == "encode") plan.source = Source::encode;
  else return plan_error(plan_path, "source is not render or encode");
  if (!j.value("request", json()).is_object()) return plan_error(plan_path, "request is not an object");
  plan.request = j["request"];
  plan.fingerprint = j.value("fingerprint", "");
  const json& track = j.value("track", json());
  if (!track.is_array() || static_cast<int>(track.size()) != plan.frames)
    return plan_error(plan_path, fmt::format("the track does not hold {} frames", plan.frames));
  for (const auto& t : track) {
    auto d = decision_from_json(t);
    if (!d) return plan_error(plan_path, d.error().message);
    plan.track.push_back(*d);
  }
  const json& ranges = j.value("ranges", json());
  if (!ranges.is_array() || static_cast<int>(ranges.size()) != plan.shards)
    return plan_error(plan_path, fmt::format("ranges does not hold {} shards", plan.shards));
  int next = 0;
  for (const auto& r : ranges) {
    const int first = r.value("first_frame", -1), count = r.value("frame_count", 0);
    if (first != next || count < 1 || first + count > plan.frames)
      return plan_error(plan_path, fmt::format("shard {}'s frames do not follow the shard before", plan.ranges.size()));
    plan.ranges.emplace_back(first, count);
    next = first + count;
  }
  if (next != plan.frames) return plan_error(plan_path, "the ranges do not cover every frame");
  if (plan.fingerprint != fingerprint_of(plan, track, ranges))
    return plan_error(plan_path, "its fingerprint does not match its contents (edited after it was made?)");
  return plan;
}

Result<FrameRequest> plan_request(const SequencePlan& plan) { return parse_request_json(plan.request, plan_context(plan.source)); }

Result<SequenceResult> run_sequence_shard(const SequencePlan& plan, int shard, SequenceOptions options) {
  if (shard < 0 || shard >= plan.shards)
    return make_error("request.value", fmt::format("--shard {}: the plan has shards 0..{}", shard, plan.shards - 1), "shard");
  auto request = plan_request(plan);
  if (!request) return request.error();
  ShardSpec spec;
  spec.shard = shard;
  spec.first_frame = plan.ranges[static_cast<std::size_t>(shard)].first;
  spec.frame_count = plan.ranges[static_cast<std::size_t>(shard)].second;
  spec.scenes_before = static_cast<int>(std::count_if(plan.track.begin(), plan.track.begin() + spec.first_frame,
                                                      [](const auto& d) { return d.scene_start; }));
  spec.track = &plan.track;
  spec.work_dir = plan.resolved_work_dir();
  spec.fingerprint = plan.fingerprint;
  // A rerun starts clean: its previous .done goes first, so nothing mistakes a half-rewritten
  // shard for a finished one.
  std::error_code ec;
  fs::remove(spec.work_dir / fmt::format("shard-{}.done", shard), ec);
  options.shard = spec;
  return run_sequence(*request, spec.work_dir / fmt::format("shard-{}", shard), options);
}

Result<SequenceResult> merge_sequence_plan(const SequencePlan& plan, const fs::path& outbase) {
  auto request = plan_request(plan);
  if (!request) return request.error();
  const fs::path work = plan.resolved_work_dir();
  std::vector<fs::path> stats;
  for (int i = 0; i < plan.shards; ++i) {
    const fs::path done = work / fmt::format("shard-{}.done", i);
    std::ifstream in(done);
    std::string fp;
    if (!in || !std::getline(in, fp))
      return make_error("sequence.shard", fmt::format("shard {} of {} is missing (no {})", i, plan.shards, done.string()));
    if (fp != plan.fingerprint)
      return make_error("sequence.shard", fmt::format("shard {} of {} was made from another plan ({} says {}, the plan {})", i,
                                                      plan.shards, done.filename().string(), fp, plan.fingerprint));
    stats.push_back(work / fmt::format("shard-{}.json", i));
  }
  return merge_sequence_shards(*request, stats, plan.fingerprint, outbase);
}

}  // namespace hdrd::job

// POST /v1/pattern and POST /v1/selftest (docs/api.md): the standard test patterns and the
// display-mode suite of patterns/ (issue 7), behind the same request validation, content
// negotiation, scheduling and dumps as /v1/render.
#include <mutex>

#include <fmt/format.h>

#include "daemon/api_support.hpp"
#include "daemon/memory.hpp"
#include "daemon/output.hpp"
#include "daemon/pattern_catalogue.hpp"
#include "daemon/render_worker.hpp"
#include "daemon/service.hpp"
#include "encode/pipeline.hpp"

#if defined(HDRD_PATTERNS_AVAILABLE) && __has_include("patterns/patterns.hpp")
#include "patterns/patterns.hpp"
#include "patterns/selftest.hpp"
#define HDRD_HAVE_PATTERNS 1
#endif

namespace hdrd::daemon {

using nlohmann::json;

#ifdef HDRD_HAVE_PATTERNS
namespace {

// ---- patterns -----------------------------------------------------------------------------

struct PatternJobState {
  Request request;
  OutputKind output = OutputKind::png;
  std::string dump_name;
  std::shared_ptr<const Config> config;
};

patterns::PatternOptions pattern_options(const Request& q) {
  patterns::PatternOptions o;
  o.width = q.width;
  o.height = q.height;
  o.level_nits = q.pattern.level_nits;
  o.area_percent = q.pattern.area_percent;
  o.steps = q.pattern.steps;
  o.labels = q.pattern.labels;
  return o;
}

// The pattern library names its own options (--level, --area, --mode); the API's are
// request fields.
Error as_request_error(Error e) {
  if (e.field == "mode") e.field = "display.mode";
  else if (e.field == "level") e.field = "params.level_nits";
  else if (e.field == "area") e.field = "params.area_percent";
  return e;
}

// What the client should know about the frame it gets: BT.2111 bars are narrow-range
// 10-bit whatever the display said; a level above the peak is clipped by the encoder.
void pattern_notes(const EncodedFrame& f, const DisplayTarget& asked, std::vector<std::string>* warnings) {
  const std::string name = f.settings["pattern"]["name"].get<std::string>();
  if (f.target.range != asked.range || f.target.bits != asked.bits)
    warnings->push_back(fmt::format("{} is defined as {}-bit {} range codes: sent that way", name, f.target.bits,
                                    to_string(f.target.range)));
  if (f.settings["pattern"].contains("note")) warnings->push_back(f.settings["pattern"]["note"].get<std::string>());
}

Reply pattern_finish(const PatternJobState& st, Metrics& metrics) {
  const Request& q = st.request;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> warnings;
  auto target = resolve_display(q.display, &warnings);
  if (!target) return Reply::error(target.error());
  auto frame = patterns::make_pattern(q.pattern.name, *target, pattern_options(q), needs_display_nits(q, st.output));
  if (!frame) return Reply::error(as_request_error(frame.error()));
  pattern_notes(*frame, *target, &warnings);
  const double encode_s = seconds_since(t0);
  metrics.stage_time("encode", encode_s);
  const auto t1 = std::chrono::steady_clock::now();
  auto reply = answer_frame(*frame, q, st.output, st.config->paths.dump_dir, st.dump_name, warnings);
  if (!reply) return Reply::error(reply.error());
  metrics.stage_time("serialize", seconds_since(t1));
  reply->headers.emplace_back("X-Hdrd-Pattern", q.pattern.name);
  reply->headers.emplace_back("X-Hdrd-Encode-Ms", fmt::format("{:.1f}", encode_s * 1e3));
  return std::move(*reply);
}

// ---- the display-mode suite ---------------------------------------------------------------

struct RenderedScene {
  std::string name;
  Result<Image> scene_nits = make_error("render.none", "not rendered");
};

struct SelftestJobState {
  SelftestRequest request;
  DisplayTarget target;
  std::string skip_render;  // why the scenes are not rendered ("" when they are)
  std::vector<RenderedScene> scenes;
  double render_s = 0;
};

// The suite's scene size (patterns::SuiteOptions' default): enough to exercise the
// pipeline, small enough to keep a self-test well under a second on llvmpipe.
constexpr int kSceneWidth = 96, kSceneHeight = 54;

#ifdef HDRD_HAVE_RENDERER
// Render stage, on a render worker with its own renderer: the built-in scenes, as
// patterns::run_suite renders them when it owns a renderer (it would otherwise create a
// second GL context on an encode thread).
Result<void> selftest_render(SelftestJobState& st, RenderResource* res, const JobControl& control) {
  auto* rr = dynamic_cast<RendererResource*>(res);
  if (!rr) {
    st.skip_render = "no renderer on this worker";
    return {};
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& name : shading::builtin_scene_names()) {
    if (control.should_stop()) break;
    shading::RenderRequest q;
    q.scene = name, q.width = kSceneWidth, q.height = kSceneHeight, q.samples = 1;
    auto r = rr->renderer->render(q);
    st.scenes.push_back({name, r ? Result<Image>(std::move(r->scene_nits)) : Result<Image>(r.error())});
  }
  st.render_s = seconds_since(t0);
  return {};
}
#endif

// The rendered scenes' checks, as patterns::run_suite makes them: histogram exposure,
// then no code above the peak and MaxCLL/MaxFALL equal to the decoded codes.
void scene_checks(const SelftestJobState& st, patterns::Report& report) {
  if (!st.skip_render.empty()) {
    report.checks.push_back({"render", "shading: offscreen GL", true, true, "skipped: " + st.skip_render});
    return;
  }
  for (const auto& s : st.scenes) {
    if (!s.scene_nits) {
      report.checks.push_back({"render/" + s.name, "shading", false, false, s.scene_nits.error().message});
      continue;
    }
    EncodeSettings settings;
    settings.target = st.target;
    settings.exposure.mode = exposure::Mode::histogram;
    SceneInput in;
    in.image = &*s.scene_nits;
    in.units = InputUnits::absolute;
    auto f = encode_frame(in, settings);
    if (!f) {
      report.checks.push_back({"render/" + s.name, "encode", false, false, f.error().message});
      continue;
    }
    report.checks.push_back(patterns::check_peak(*f, "scene-" + s.name));
    report.checks.push_back(patterns::check_content_light(*f, "scene-" + s.name));
  }
}

// patterns::run_suite writes its EXR check into one temporary directory per process, so
// two suites must not run at the same time in the daemon.
std::mutex& suite_mutex() {
  static std::mutex mu;
  return mu;
}

Reply selftest_finish(const SelftestJobState& st) {
  patterns::Report report;
  {
    std::lock_guard lock(suite_mutex());
    patterns::SuiteOptions options;
    options.render = false;  // rendered on the render worker instead (selftest_render)
    report = patterns::run_suite(st.target, st.request.mode, options);
  }
  scene_checks(st, report);
  report.seconds += st.render_s;
  Reply r = json_reply(report.to_json());
  r.headers.emplace_back("X-Hdrd-Selftest", report.passed() ? "passed" : "failed");
  return r;
}

}  // namespace
#endif

json Service::pattern_capabilities() {
  json out = json::array();
  for (const auto& entry : pattern_catalogue()) {
    json j = pattern_entry_json(entry);
#ifdef HDRD_HAVE_PATTERNS
    if (const auto* info = patterns::find_pattern(entry.name)) {
      j["description"] = info->description;
      j["source"] = info->source;
    }
#endif
    out.push_back(std::move(j));
  }
  return out;
}

void Service::post_pattern(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  ParseContext ctx{Endpoint::pattern, cfg->limits, cfg->render, cfg->paths.asset_root};
  auto req = parse_request(http.body, ctx);
  if (!req) return responder->reply(Reply::error(req.error()));
  auto output = negotiate_output(http.header("accept"), req->display.target.mode, req->dump);
  if (!output) return responder->reply(Reply::error(output.error()));
#ifndef HDRD_HAVE_PATTERNS
  responder->reply(Reply::error(make_error("pipeline.unavailable", "test patterns are not available in this build")));
#else
  auto st = std::make_shared<PatternJobState>();
  st->request = std::move(*req);
  st->output = *output;
  st->config = cfg;
  st->dump_name = st->request.name.empty() ? generated_name("pattern", http.id) : st->request.name;
  JobSpec spec;
  spec.deadline = request_deadline(http, st->request.timeout_s, *cfg);
  if (!st->request.dump) spec.key = canonical_key(st->request.canonical()) + "|" + std::string(content_type(*output));
  spec.memory_bytes = estimate_pattern_memory(st->request, *output, http.body.size());  // memory.hpp
  Metrics* metrics = &metrics_;
  spec.finish = [st, metrics](const JobControl&) { return pattern_finish(*st, *metrics); };
  submit(std::move(spec), false, responder);
#endif
}

void Service::post_selftest(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  ParseContext ctx{Endpoint::render, cfg->limits, cfg->render, cfg->paths.asset_root};
  auto req = parse_selftest_request(http.body, ctx);
  if (!req) return responder->reply(Reply::error(req.error()));
#ifndef HDRD_HAVE_PATTERNS
  responder->reply(
      Reply::error(make_error("pipeline.unavailable", "the display-mode suite is not available in this build")));
#else
  auto target = patterns::suite_target(req->mode, req->peak_nits);
  if (!target) {
    Error e = target.error();
    e.code = "request.value";
    e.field = req->peak_nits ? "peak_nits" : "mode";
    return responder->reply(Reply::error(e));
  }
  auto st = std::make_shared<SelftestJobState>();
  st->request = *req;
  st->target = *target;
  const bool render = req->render && scheduler_ && scheduler_->renderer_available();
  if (!req->render) st->skip_render = "the request asked for no rendering (\"render\": false)";
  else if (!render) st->skip_render = "no renderer in this daemon";
  JobSpec spec;
  spec.deadline = request_deadline(http, req->timeout_s, *cfg);
  spec.key = canonical_key(req->canonical());
#ifdef HDRD_HAVE_RENDERER
  if (render)
    spec.render = [st](RenderResource* res, const JobControl& control) { return selftest_render(*st, res, control); };
#endif
  spec.finish = [st](const JobControl&) { return selftest_finish(*st); };
  submit(std::move(spec), render, responder);
#endif
}

}  // namespace hdrd::daemon

// POST /v1/selftest (docs/api.md): the display-mode suite of patterns/ for one mode, its
// built-in scenes rendered on a render worker; and the pattern list GET /v1/capabilities
// publishes. (POST /v1/pattern is a frame job: api_frame.cpp.)
#include <algorithm>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "daemon/api/support.hpp"
#include "daemon/jobs/render_worker.hpp"
#include "daemon/service.hpp"
#include "encode/pipeline.hpp"
#include "job/pattern_params.hpp"
#include "patterns/patterns.hpp"
#include "patterns/selftest.hpp"

namespace hdrd::daemon {

using nlohmann::json;

namespace {

// ---- the display-mode suite ---------------------------------------------------------------

// POST /v1/selftest's body: {"mode", "peak_nits", "render", "timeout_s"}, all optional (an
// empty body is hdr10 at its default peak, as `hdrd selftest` without options).
struct SelftestRequest {
  std::string mode = "hdr10";             // a display mode (mode_names(), or an alias)
  std::optional<double> peak_nits;        // default: the mode's
  bool render = true;                     // also render the built-in scenes
  std::optional<double> timeout_s;
  json canonical() const {
    return {{"endpoint", "selftest"}, {"mode", mode}, {"peak_nits", peak_nits ? json(*peak_nits) : json(nullptr)},
            {"render", render}};
  }
};

Result<SelftestRequest> parse_selftest_request(std::string_view body, const job::Limits& limits) {
  SelftestRequest r;
  if (body.find_first_not_of(" \t\r\n") == std::string_view::npos) return r;
  auto parsed = job::parse_json_object_bounded(body, limits, "the selftest request");
  if (!parsed) return parsed.error();
  const json& doc = *parsed;
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    const std::string& k = it.key();
    const json& v = *it;
    const std::string shown = one_line(k.substr(0, 64));
    if (k == "mode") {
      if (!v.is_string() || !parse_mode(v.get<std::string>()))
        return make_error("request.value", "mode: one of " + patterns::suite_modes_text(), "mode");
      r.mode = v.get<std::string>();
    } else if (k == "peak_nits" || k == "timeout_s") {
      const double max = k == "peak_nits" ? 10000 : limits.max_request_seconds;
      if (!v.is_number() || !(v.get<double>() >= 1e-3 && v.get<double>() <= max))
        return make_error("request.value", fmt::format("{}: a number in [0.001, {:g}]", k, max), k);
      (k == "peak_nits" ? r.peak_nits : r.timeout_s) = v.get<double>();
    } else if (k == "render") {
      if (!v.is_boolean()) return make_error("request.type", "render: expected true or false", "render");
      r.render = v.get<bool>();
    } else {
      return make_error("request.unknown_field", fmt::format("{}: unknown field", shown), k.substr(0, 64));
    }
  }
  return r;
}

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

json Service::pattern_capabilities() {
  json out = json::array();
  for (const auto& entry : job::pattern_catalogue()) {
    json j = job::pattern_entry_json(entry);
    if (const auto* info = patterns::find_pattern(entry.name)) {
      j["description"] = info->description;
      j["source"] = info->source;
    }
    out.push_back(std::move(j));
  }
  return out;
}

void Service::post_selftest(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  auto req = parse_selftest_request(http.body, cfg->limits);
  if (!req) return responder->reply(Reply::error(req.error()));
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
  if (render)
    spec.render = [st](RenderResource* res, const JobControl& control) { return selftest_render(*st, res, control); };
  spec.finish = [st](const JobControl&) { return selftest_finish(*st); };
  submit(std::move(spec), render, responder);
}

}  // namespace hdrd::daemon

// The v1 API: a table of routes and one small handler per endpoint (docs/api.md).
// begin() and handle() are the noexcept boundary: every failure inside becomes a JSON
// error reply with its HTTP status (wire_error.cpp), never an escaped exception.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/api_support.hpp"
#include "daemon/input_bounds.hpp"
#include "daemon/memory.hpp"
#include "daemon/output.hpp"
#include "daemon/render_worker.hpp"
#include "daemon/service.hpp"
#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/tonemap.hpp"

#if defined(HDRD_DISPLAY_AVAILABLE) && __has_include("display/displays.hpp")
#include "display/displays.hpp"
#define HDRD_HAVE_DISPLAYS 1
#endif

#ifndef HDRD_DAEMON_VERSION
#define HDRD_DAEMON_VERSION "0"
#endif

namespace hdrd::daemon {

using nlohmann::json;

enum class BodyKind { none, json, upload };

struct Service::Route {
  std::string_view method;
  std::string_view path;
  void (Service::*handler)(HttpRequest&, std::shared_ptr<Responder>);
  BodyKind body;
};

const std::vector<Service::Route>& Service::routes() {
  static const std::vector<Route> kRoutes = {
      {"GET", "/v1/status", &Service::get_status, BodyKind::none},
      {"GET", "/v1/capabilities", &Service::get_capabilities, BodyKind::none},
      {"GET", "/v1/displays", &Service::get_displays, BodyKind::none},
      {"GET", "/metrics", &Service::get_metrics, BodyKind::none},
      {"POST", "/v1/render", &Service::post_render, BodyKind::json},
      {"POST", "/v1/encode", &Service::post_encode, BodyKind::upload},
      {"POST", "/v1/pattern", &Service::post_pattern, BodyKind::json},
      {"POST", "/v1/selftest", &Service::post_selftest, BodyKind::json},
  };
  return kRoutes;
}

namespace {

constexpr std::size_t kNoBodyLimit = 4096;  // GET requests: a stray body is tolerated, not stored beyond this

// Constant-time comparison, so the bearer token cannot be guessed byte by byte.
bool same_secret(std::string_view a, std::string_view b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i % std::max<std::size_t>(b.size(), 1)]);
  return diff == 0;
}

std::uint64_t fnv1a(std::string_view s, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string endpoint_label(const HttpRequest& r) {
  for (auto p : {"/v1/status", "/v1/capabilities", "/v1/displays", "/metrics", "/v1/render", "/v1/encode",
                 "/v1/pattern", "/v1/selftest"})
    if (r.path == p) return p;
  return "other";
}

// Everything a render job carries from the render worker to the encode pool.
struct RenderJobState {
  Request request;
  OutputKind output = OutputKind::png;
  std::string dump_name;
  std::shared_ptr<const Config> config;
#ifdef HDRD_HAVE_RENDERER
  shading::RenderResult rendered;
#endif
  double render_s = 0;
};

struct EncodeJobState {
  Request request;
  OutputKind output = OutputKind::png;
  std::string dump_name;
  std::shared_ptr<const Config> config;
  std::string exr;  // the uploaded file
};

int encode_threads_per_job(const Config& c) {
  const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, hw / std::max(1, c.workers.encode_threads));
}

// Encodes a scene-referred input and answers in the negotiated form.
Reply encode_and_reply(const SceneInput& in, const Request& req, OutputKind output, const std::string& dump_name,
                       const Config& cfg, exposure::Mode default_exposure, std::vector<std::string> warnings,
                       json extra_settings, Metrics& metrics) {
  const auto t0 = std::chrono::steady_clock::now();
  auto target = resolve_display(req.display, &warnings);
  if (!target) return Reply::error(target.error());
  auto settings = build_encode_settings(req, *target, default_exposure, encode_threads_per_job(cfg), &warnings);
  if (!settings) return Reply::error(settings.error());
  settings->keep_display_nits = needs_display_nits(req, output);
  auto frame = encode_frame(in, *settings);
  if (!frame) return Reply::error(frame.error());
  for (auto& [k, v] : extra_settings.items()) frame->settings[k] = v;
  const double encode_s = seconds_since(t0);
  metrics.stage_time("encode", encode_s);
  const auto t1 = std::chrono::steady_clock::now();
  auto reply = answer_frame(*frame, req, output, cfg.paths.dump_dir, dump_name, warnings);
  if (!reply) return Reply::error(reply.error());
  metrics.stage_time("serialize", seconds_since(t1));
  reply->headers.emplace_back("X-Hdrd-Encode-Ms", fmt::format("{:.1f}", encode_s * 1e3));
  return std::move(*reply);
}

#ifdef HDRD_HAVE_RENDERER
// The renderer's request for a validated daemon request.
shading::RenderRequest to_render_request(const Request& q, const Config& cfg) {
  shading::RenderRequest rq;
  switch (q.scene.kind) {
    case SceneSpec::Kind::builtin: rq.scene = q.scene.name; break;
    case SceneSpec::Kind::inline_json: rq.scene_json = q.scene.inline_scene; break;
    case SceneSpec::Kind::scene_file:
    case SceneSpec::Kind::gltf: rq.scene = q.scene.path.string(); break;
  }
  rq.width = q.width;
  rq.height = q.height;
  rq.samples = std::min(q.samples, shading::kMaxSamples);
  const auto vec = [](const std::array<double, 3>& v) { return shading::Vec3{v[0], v[1], v[2]}; };
  if (q.camera.position || q.camera.target || q.camera.fov_y_deg) {
    shading::CameraOverride cam;
    if (q.camera.position) cam.position = vec(*q.camera.position);
    if (q.camera.target) cam.target = vec(*q.camera.target);
    cam.yfov_deg = q.camera.fov_y_deg;
    rq.camera = cam;
  }
  // Files named by a request were resolved inside the asset root; JSON scenes may not
  // reach further files (their paths are not checked against the root).
  rq.load.allow_files = false;
  rq.load.base_dir = cfg.paths.asset_root.empty() ? std::filesystem::path("/nonexistent") : cfg.paths.asset_root;
  rq.load.limits.max_lights = cfg.limits.max_lights;
  return rq;
}

// Render stage (on a render worker, with its renderer): the scene-referred frame.
Result<void> render_stage(RenderJobState& st, RenderResource* res, Metrics& metrics) {
  auto* rr = dynamic_cast<RendererResource*>(res);
  if (!rr) return make_error("renderer.unavailable", "renderer not available on this worker");
  const Request& q = st.request;
  const shading::RenderRequest rq = to_render_request(q, *st.config);
  const auto t0 = std::chrono::steady_clock::now();
  auto r = rr->renderer->render(rq);
  if (!r) {
    Error e = r.error();
    // Fields inside an inline scene are reported relative to the request.
    if (q.scene.kind == SceneSpec::Kind::inline_json && !e.field.empty() && e.field.rfind("scene", 0) != 0)
      e.field = "scene." + e.field;
    return e;
  }
  st.rendered = std::move(*r);
  st.render_s = seconds_since(t0);
  metrics.stage_time("render", st.render_s);
  return {};
}

// Encode stage (on the encode pool): exposure, tone curve, encoding, the reply.
Reply render_finish(RenderJobState& st, Metrics& metrics) {
  const auto& rd = st.rendered;
  SceneInput in;
  in.image = &rd.scene_nits;
  in.to_working = color::to_working(color::Space::rec709);
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  if (rd.dominant_illuminance_lux > 0) in.illuminance_lux = rd.dominant_illuminance_lux;
  // Renders are absolute light: meter the lighting (RTR4: incident metering) when the
  // scene has a light, else the log-average of the frame.
  const auto default_exposure =
      rd.dominant_illuminance_lux > 0 ? exposure::Mode::light : exposure::Mode::log_average;
  json extra = {{"render",
                 {{"scene", rd.scene_name}, {"backend", rd.backend}, {"gl_renderer", rd.gl_renderer},
                  {"samples", rd.samples}, {"render_ms", rd.render_ms},
                  {"dominant_illuminance_lux", rd.dominant_illuminance_lux}}}};
  Reply reply = encode_and_reply(in, st.request, st.output, st.dump_name, *st.config, default_exposure,
                                 rd.warnings, extra, metrics);
  reply.headers.emplace_back("X-Hdrd-Render-Ms", fmt::format("{:.1f}", st.render_s * 1e3));
  reply.headers.emplace_back("X-Hdrd-Scene", rd.scene_name);
  reply.headers.emplace_back("X-Hdrd-Backend", rd.backend);
  return reply;
}

#endif

// /v1/encode's only stage (on the encode pool): decode the upload, encode, reply.
Reply encode_finish(EncodeJobState& st, const JobControl& control, Metrics& metrics) {
  const auto t0 = std::chrono::steady_clock::now();
  auto exr = io::read_exr_memory(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(st.exr.data()), st.exr.size()));
  if (!exr) return Reply::error(exr.error());
  metrics.stage_time("decode", seconds_since(t0));
  if (control.should_stop()) return Reply::error(make_error("request.cancelled", "cancelled"));
  SceneInput in;
  in.image = &exr->image;
  in.to_working = exr->to_working();
  // REFERENCE.md §1.1: relative unless the file has whiteLuminance or the request says.
  const auto& q = st.request;
  in.units = q.input.empty() ? (exr->white_luminance ? InputUnits::absolute : InputUnits::relative)
                             : *parse_input_units(q.input);
  in.white_luminance_nits = exr->white_luminance.value_or(1.0);
  std::vector<std::string> warnings = exr->warnings;
  if (in.units == InputUnits::absolute && !exr->white_luminance)
    warnings.push_back("input absolute without whiteLuminance: values are taken as cd/m2");
  json extra = {{"input", {{"units", to_string(in.units)}, {"white_luminance_nits", in.white_luminance_nits},
                           {"channels", exr->channels}, {"bytes", st.exr.size()}}}};
  return encode_and_reply(in, q, st.output, st.dump_name, *st.config, exposure::Mode::manual, warnings, extra,
                          metrics);
}

}  // namespace

const Service::Route* Service::find_route(const HttpRequest& r, std::string* allow) const {
  const Route* path_match = nullptr;
  for (const auto& route : routes()) {
    if (route.path != r.path) continue;
    path_match = &route;
    const bool method_ok = route.method == r.method || (route.method == "GET" && r.method == "HEAD");
    if (method_ok) return &route;
  }
  if (path_match && allow) {
    for (const auto& route : routes())
      if (route.path == r.path) *allow += (allow->empty() ? "" : ", ") + std::string(route.method);
  }
  return nullptr;
}

std::variant<std::size_t, Reply> Service::begin(const HttpRequest& r) noexcept {
  try {
    if (r.tcp) {
      const std::string* auth = r.header("authorization");
      const std::string prefix = "Bearer ";
      if (!auth || auth->rfind(prefix, 0) != 0 || !same_secret(auth->substr(prefix.size()), token_)) {
        Reply rep = Reply::error(make_error("request.unauthorized", "TCP requests need 'Authorization: Bearer <token>'",
                                            "authorization"));
        rep.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"hdrd\"");
        return rep;
      }
    }
    std::string allow;
    const Route* route = find_route(r, &allow);
    if (!route) {
      if (!allow.empty()) {
        Reply rep = Reply::error(make_error("request.method", fmt::format("{} is not allowed on {} (allowed: {})",
                                                                           r.method.substr(0, 16), r.path, allow)));
        rep.headers.emplace_back("Allow", allow);
        return rep;
      }
      return Reply::error(make_error("request.not_found", fmt::format("no endpoint {}", r.path.substr(0, 200))));
    }
    const auto cfg = config();
    switch (route->body) {
      case BodyKind::none: return kNoBodyLimit;
      case BodyKind::json: return cfg->limits.max_body_bytes;
      case BodyKind::upload: return cfg->limits.max_upload_bytes;
    }
    return kNoBodyLimit;
  } catch (const std::exception& e) {
    return Reply::error(make_error("internal", std::string("internal error: ") + e.what()));
  }
}

void Service::handle(HttpRequest& r, std::shared_ptr<Responder> responder) noexcept {
  try {
    const Route* route = find_route(r, nullptr);
    if (!route) {
      responder->reply(Reply::error(make_error("request.not_found", "no endpoint " + r.path.substr(0, 200))));
      return;
    }
    (this->*route->handler)(r, responder);
  } catch (const HdrdError& e) {
    responder->reply(Reply::error(e.error()));
  } catch (const std::exception& e) {
    spdlog::error("request {} {} {}: {}", r.id, r.method, r.path, e.what());
    responder->reply(Reply::error(make_error("internal", std::string("internal error: ") + e.what())));
  } catch (...) {
    responder->reply(Reply::error(make_error("internal", "internal error")));
  }
}

void Service::finished(const HttpRequest& r, const Reply& reply, std::size_t body_bytes) noexcept {
  try {
    const double s = seconds_since(r.started);
    metrics_.request_finished(endpoint_label(r), reply.status, s, body_bytes, reply.body ? reply.body->size() : 0);
    if (config()->log.access_log) {
      const std::string peer = r.peer ? fmt::format("uid={} gid={} pid={}", r.peer->uid, r.peer->gid, r.peer->pid)
                                      : (r.tcp ? "tcp" : "unix");
      spdlog::info("#{} {} {} {} -> {} {} {} B {:.1f} ms", r.id, peer, r.method, r.path.substr(0, 200), reply.status,
                   reply.error_code.empty() ? reply.content_type : reply.error_code,
                   reply.body ? reply.body->size() : 0, s * 1e3);
    }
  } catch (...) {
  }
}

void Service::connection_opened(bool tcp, const std::optional<PeerCred>& peer) noexcept {
  ++metrics_.connections;
  if (peer) spdlog::debug("connection from pid={} uid={} gid={}", peer->pid, peer->uid, peer->gid);
  else if (tcp) spdlog::debug("TCP connection");
}

void Service::submit(JobSpec spec, bool needs_renderer, const std::shared_ptr<Responder>& responder) {
  const auto deadline = spec.deadline;
  const auto memory_bytes = spec.memory_bytes;
  Metrics* metrics = &metrics_;
  auto waiter = scheduler_->submit(
      std::move(spec),
      [responder, metrics, memory_bytes](std::shared_ptr<const Reply> reply, bool coalesced) {
        Reply r = *reply;
        if (memory_bytes) r.headers.emplace_back("X-Hdrd-Memory-Estimate", std::to_string(memory_bytes));  // memory.hpp
        if (coalesced) {
          r.headers.emplace_back("X-Hdrd-Coalesced", "true");
          ++metrics->coalesced;
        }
        responder->reply(std::move(r));
      },
      needs_renderer);
  if (!waiter) {
    Reply r = Reply::error(waiter.error());
    if (waiter.error().code.rfind("queue.", 0) == 0) {  // queue.full, queue.memory
      ++(waiter.error().code == "queue.full" ? metrics_.rejected_full : metrics_.rejected_memory);
      r.headers.emplace_back("Retry-After", std::to_string(config()->workers.retry_after_s));
    }
    responder->reply(std::move(r));
    return;
  }
  Scheduler* sched = scheduler_.get();
  // A weak reference: the waiter's delivery holds the responder, so a strong one here
  // would make a cycle that outlives the request.
  responder->on_abort([sched, metrics, weak = std::weak_ptr<Waiter>(*waiter)](const Error& why) {
    auto w = weak.lock();
    if (!w || !sched->cancel(w)) return false;
    if (why.code == "request.timeout") ++metrics->timed_out;
    else ++metrics->cancelled;
    return true;
  });
  responder->set_deadline(deadline);
}

// ---- GET endpoints --------------------------------------------------------------------

nlohmann::json Service::status_json() const {
  const auto cfg = config();
  json j;
  j["service"] = "hdrd";
  j["version"] = HDRD_DAEMON_VERSION;
  j["api_version"] = 1;
  j["pid"] = ::getpid();
  j["uptime_s"] = seconds_since(started_);
  j["listeners"] = listener_descriptions_;
  j["config_source"] = cfg->source.string();
  j["draining"] = shutting_down_.load();
  if (scheduler_) {
    const auto s = scheduler_->stats();
    j["queue"] = {{"depth", s.queued}, {"admitted", s.admitted}, {"running", s.running}, {"capacity", s.capacity},
                  {"queue_depth_limit", cfg->workers.queue_depth}};
    j["workers"] = {{"render", s.render_workers}, {"render_ready", s.render_workers_ready},
                    {"encode_threads", s.encode_threads}, {"render_workers", s.workers}};
    std::string backend, gl_renderer;
    for (const auto& w : s.workers)
      if (w.contains("backend")) {
        backend = w["backend"];
        gl_renderer = w.value("gl_renderer", "");
        break;
      }
    j["renderer"] = backend.empty() ? json{{"available", false}, {"reason", s.workers.empty() ? json("no workers")
                                                                                              : s.workers[0].value("error", json(""))}}
                                    : json{{"available", true}, {"backend", backend}, {"gl_renderer", gl_renderer}};
  }
  j["requests_in_flight"] = server_ ? server_->open_requests() : 0;
  return j;
}

void Service::get_status(HttpRequest&, std::shared_ptr<Responder> responder) {
  responder->reply(json_reply(status_json()));
}

void Service::get_capabilities(HttpRequest&, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  json modes = json::array();
  for (Mode m : {Mode::hdr10, Mode::hlg, Mode::scrgb, Mode::sdr, Mode::sdr_bt1886}) {
    const DisplayTarget t = default_target(m);
    modes.push_back({{"name", to_string(m)}, {"peak_nits", t.peak_nits}, {"black_nits", t.black_nits},
                     {"paper_white_nits", t.paper_white_nits}, {"range", to_string(t.range)}, {"bits", t.bits},
                     {"default_tone_curve", tonemap::default_curve(m)},
                     {"formats", m == Mode::scrgb ? json{"image/x-exr", "application/octet-stream"}
                                                  : json{"image/png", "image/x-exr", "application/octet-stream"}}});
  }
  json curves = json::array();
  for (const auto& c : tonemap::curves()) {
    json params = json::array();
    for (const auto& p : c.params)
      params.push_back({{"name", p.name}, {"description", p.description}, {"min", p.min}, {"max", p.max},
                        {"default", p.default_value}});
    curves.push_back({{"name", c.name}, {"description", c.description}, {"source", c.source}, {"params", params},
                      {"default_apply", tonemap::to_string(c.default_apply)}, {"scalar", c.scalar},
                      {"has_inverse", c.has_inverse}, {"keeps_reference_white", c.keeps_reference_white}});
  }
  json exposure_modes = json::array();
  for (auto m : {exposure::Mode::manual, exposure::Mode::camera, exposure::Mode::log_average, exposure::Mode::histogram,
                 exposure::Mode::light})
    exposure_modes.push_back(exposure::to_string(m));
  json scenes = json::array();
#ifdef HDRD_HAVE_RENDERER
  for (const auto& s : shading::builtin_scene_names()) scenes.push_back(s);
#endif
  const auto& l = cfg->limits;
  json j = {
      {"api_version", 1},
      {"modes", modes},
      {"tone_curves", curves},
      {"tone_apply", {"per-channel", "max-rgb", "luminance", "rgb"}},
      {"exposure_modes", exposure_modes},
      {"gamut_mapping", {"ictcp", "clip"}},
      {"grade", {{"placements", {"scene", "display", "baked"}}, {"shapers", {"pq", "log2", "sqrt", "sqrt-sqrt", "none"}}}},
      {"output_types", {"image/png", "image/x-exr", "application/octet-stream", "application/json"}},
      {"dump_formats", {"png", "exr", "raw"}},
      {"scenes", scenes},
      {"default_scene", cfg->render.scene},
      {"renderer_available", scheduler_ && scheduler_->renderer_available()},
      {"limits",
       {{"max_width", l.max_width}, {"max_height", l.max_height}, {"max_pixels", l.max_pixels},
        {"max_samples", l.max_samples}, {"max_lights", l.max_lights}, {"max_body_bytes", l.max_body_bytes},
        {"max_upload_bytes", l.max_upload_bytes}, {"max_ui_bytes", l.max_ui_bytes},
        {"max_json_depth", l.max_json_depth}, {"max_request_seconds", l.max_request_seconds}}},
      {"asset_root", !cfg->paths.asset_root.empty()},
      {"dump", !cfg->paths.dump_dir.empty()},
      {"patterns", pattern_capabilities()},
      {"selftest_modes", {"sdr-srgb", "sdr", "sdr-bt1886", "hdr10", "scrgb", "hlg"}},
  };
  responder->reply(json_reply(j));
}

void Service::get_displays(HttpRequest&, std::shared_ptr<Responder> responder) {
#ifdef HDRD_HAVE_DISPLAYS
  auto overrides = display::load_default_overrides();
  const auto report = display::enumerate_displays(overrides ? *overrides : std::vector<display::ProfileOverride>{});
  json j = display::to_json(report);
  if (!overrides) j["override_error"] = overrides.error().message;
  if (auto chosen = display::choose_auto_profile(report)) j["auto"] = display::profile_to_json(*chosen);
  else j["auto"] = nullptr;
  responder->reply(json_reply(j));
#else
  responder->reply(json_reply({{"connectors", json::array()},
                               {"note", "display queries are not available in this build (hdrd_display)"}}));
#endif
}

void Service::get_metrics(HttpRequest&, std::shared_ptr<Responder> responder) {
  std::map<std::string, double> gauges;
  gauges["hdrd_uptime_seconds"] = seconds_since(started_);
  if (scheduler_) {
    const auto s = scheduler_->stats();
    gauges["hdrd_queue_depth"] = s.queued;
    gauges["hdrd_jobs_admitted"] = s.admitted;
    gauges["hdrd_jobs_running"] = s.running;
    gauges["hdrd_queue_capacity"] = s.capacity;
    gauges["hdrd_render_workers_ready"] = s.render_workers_ready;
    gauges["hdrd_encode_threads"] = s.encode_threads;
  }
  add_resource_gauges(gauges, scheduler_.get(), server_.get());  // metrics.hpp: memory, connections
  if (server_) metrics_.in_flight = server_->open_requests();
  Reply r = Reply::json(200, metrics_.prometheus_text(gauges));
  r.content_type = "text/plain; version=0.0.4; charset=utf-8";
  responder->reply(std::move(r));
}

// ---- POST /v1/render --------------------------------------------------------------------

void Service::post_render(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  ParseContext ctx{Endpoint::render, cfg->limits, cfg->render, cfg->paths.asset_root};
  auto req = parse_request(http.body, ctx);
  if (!req) return responder->reply(Reply::error(req.error()));
  auto output = negotiate_output(http.header("accept"), req->display.target.mode, req->dump);
  if (!output) return responder->reply(Reply::error(output.error()));
#ifndef HDRD_HAVE_RENDERER
  responder->reply(Reply::error(make_error("renderer.unavailable", "renderer not available in this build")));
#else
  if (req->scene.kind == SceneSpec::Kind::builtin && !shading::is_builtin_scene(req->scene.name)) {
    std::string names;
    for (const auto& n : shading::builtin_scene_names()) names += (names.empty() ? "" : ", ") + n;
    return responder->reply(Reply::error(
        make_error("request.value", fmt::format("scene: no built-in scene '{}' (one of: {})", req->scene.name, names),
                   "scene")));
  }
  auto st = std::make_shared<RenderJobState>();
  st->request = std::move(*req);
  st->output = *output;
  st->config = cfg;
  st->dump_name = st->request.name.empty() ? generated_name("render", http.id) : st->request.name;
  JobSpec spec;
  spec.deadline = request_deadline(http, st->request.timeout_s, *cfg);
  if (!st->request.dump) spec.key = canonical_key(st->request.canonical()) + "|" + std::string(content_type(*output));
  auto memory = estimate_render_memory(st->request, *output, http.body.size(), cfg->limits);  // memory.hpp
  if (!memory) return responder->reply(Reply::error(memory.error()));
  spec.memory_bytes = *memory;
  Metrics* metrics = &metrics_;
  spec.render = [st, metrics](RenderResource* res, const JobControl&) { return render_stage(*st, res, *metrics); };
  spec.finish = [st, metrics](const JobControl&) { return render_finish(*st, *metrics); };
  submit(std::move(spec), true, responder);
#endif
}

// ---- POST /v1/encode --------------------------------------------------------------------

void Service::post_encode(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  json options = json::object();
  std::string exr;
  if (http.multipart) {
    if (!http.query.empty())
      return responder->reply(Reply::error(make_error(
          "request.conflict", "multipart uploads carry their options in the 'request' part, not the query string",
          http.query[0].first.substr(0, 64))));
    auto upload = split_encode_upload(http.parts, cfg->limits);  // input_bounds.hpp: bounded JSON part
    if (!upload) return responder->reply(Reply::error(upload.error()));
    options = std::move(upload->options);
    exr = std::move(upload->exr);
  } else {
    const std::string mt = media_type(http);
    if (mt != "image/x-exr" && mt != "application/octet-stream" && mt != "image/aces")
      return responder->reply(Reply::error(make_error(
          "request.media_type",
          "POST /v1/encode takes an OpenEXR body (Content-Type: image/x-exr) or multipart/form-data")));
    auto q = query_to_request_json(http.query);
    if (!q) return responder->reply(Reply::error(q.error()));
    options = std::move(*q);
    exr = std::move(http.body);
  }
  if (exr.empty()) return responder->reply(Reply::error(make_error("request.value", "empty EXR upload", "image")));
  if (json_nesting_depth(options.dump()) > cfg->limits.max_json_depth)
    return responder->reply(Reply::error(make_error("request.depth", "request: JSON nested too deeply")));
  ParseContext ctx{Endpoint::encode, cfg->limits, cfg->render, cfg->paths.asset_root};
  auto req = parse_request_json(options, ctx);
  if (!req) return responder->reply(Reply::error(req.error()));
  auto output = negotiate_output(http.header("accept"), req->display.target.mode, req->dump);
  if (!output) return responder->reply(Reply::error(output.error()));

  auto st = std::make_shared<EncodeJobState>();
  st->request = std::move(*req);
  st->output = *output;
  st->config = cfg;
  st->exr = std::move(exr);
  st->dump_name = st->request.name.empty() ? generated_name("encode", http.id) : st->request.name;
  JobSpec spec;
  spec.deadline = request_deadline(http, st->request.timeout_s, *cfg);
  if (!st->request.dump)
    spec.key = canonical_key(st->request.canonical()) + "|" + std::string(content_type(*output)) +
               fmt::format("|exr:{}:{:016x}", st->exr.size(), fnv1a(st->exr));
  const auto* exr_bytes = reinterpret_cast<const std::uint8_t*>(st->exr.data());
  auto memory = estimate_encode_memory(st->request, *output, {exr_bytes, st->exr.size()}, cfg->limits);  // memory.hpp
  if (!memory) return responder->reply(Reply::error(memory.error()));
  spec.memory_bytes = *memory;
  Metrics* metrics = &metrics_;
  spec.finish = [st, metrics](const JobControl& control) { return encode_finish(*st, control, *metrics); };
  submit(std::move(spec), false, responder);
}

}  // namespace hdrd::daemon

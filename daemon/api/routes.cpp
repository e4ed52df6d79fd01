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

#include "daemon/api/support.hpp"
#include "daemon/jobs/render_worker.hpp"
#include "daemon/service.hpp"
#include "display/displays.hpp"
#include "encode/tone/tonemap.hpp"
#include "job/outputs.hpp"
#include "job/settings.hpp"
#include "shading/scene_loader.hpp"

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
      {"POST", "/v1/sequences", &Service::post_sequences, BodyKind::json},
      {"GET", "/v1/jobs", &Service::get_jobs, BodyKind::none},
      // A path ending in '*': every path below it (the job's id, its result, its sidecar).
      {"GET", "/v1/jobs/*", &Service::get_job, BodyKind::none},
      {"DELETE", "/v1/jobs/*", &Service::delete_job, BodyKind::none},
      {"POST", "/v1/cluster/submissions", &Service::post_cluster_submission, BodyKind::json},
      {"GET", "/v1/cluster/submissions/*", &Service::get_cluster_submission, BodyKind::none},
      {"DELETE", "/v1/cluster/submissions/*", &Service::delete_cluster_submission, BodyKind::none},
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

// `path` is the route's: exact, or a prefix when it ends in '*' (something must follow).
bool route_matches(std::string_view route, std::string_view path) {
  if (route.empty() || route.back() != '*') return route == path;
  const std::string_view prefix = route.substr(0, route.size() - 1);
  return path.size() > prefix.size() && path.substr(0, prefix.size()) == prefix;
}

std::string endpoint_label(const HttpRequest& r) {
  for (auto p : {"/v1/status", "/v1/capabilities", "/v1/displays", "/metrics", "/v1/render", "/v1/encode",
                 "/v1/pattern", "/v1/selftest", "/v1/sequences", "/v1/jobs"})
    if (r.path == p) return p;
  if (route_matches("/v1/jobs/*", r.path)) return "/v1/jobs/{id}";
  return "other";
}

}  // namespace

const Service::Route* Service::find_route(const HttpRequest& r, std::string* allow) const {
  const Route* path_match = nullptr;
  for (const auto& route : routes()) {
    if (!route_matches(route.path, r.path)) continue;
    path_match = &route;
    const bool method_ok = route.method == r.method || (route.method == "GET" && r.method == "HEAD");
    if (method_ok) return &route;
  }
  if (path_match && allow) {
    for (const auto& route : routes())
      if (route_matches(route.path, r.path)) *allow += (allow->empty() ? "" : ", ") + std::string(route.method);
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
    metrics_.request_finished(endpoint_label(r), reply.status, s, body_bytes, reply.body_size());
    if (config()->log.access_log) {
      const std::string peer = r.peer ? fmt::format("uid={} gid={} pid={}", r.peer->uid, r.peer->gid, r.peer->pid)
                                      : (r.tcp ? "tcp" : "unix");
      spdlog::info("#{} {} {} {} -> {} {} {} B {:.1f} ms", r.id, peer, r.method, r.path.substr(0, 200), reply.status,
                   reply.error_code.empty() ? reply.content_type : reply.error_code,
                   reply.body_size(), s * 1e3);
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
  if (jobs_) {
    const auto s = jobs_->stats();
    j["sequences"] = {{"queued", s.queued}, {"running", s.running}, {"finished", s.finished},
                      {"max_running", cfg->sequences.max_running}, {"max_queued", cfg->sequences.max_queued},
                      {"memory_in_flight_bytes", s.memory_in_flight_bytes}, {"memory_kept_bytes", s.memory_kept_bytes}};
  }
  if (cluster_) {
    const auto [submissions, bytes] = cluster_kept();
    j["cluster"] = {{"submissions_kept", submissions}, {"kept_bytes", bytes}};
  }
  j["requests_in_flight"] = server_ ? server_->open_requests() : 0;
  return j;
}

void Service::get_status(HttpRequest&, std::shared_ptr<Responder> responder) {
  responder->reply(json_reply(status_json()));
}

namespace {

std::vector<std::string> choices_of(std::string_view path) {
  const job::Setting* s = job::find_setting(path);
  return std::vector<std::string>(s->choices.begin(), s->choices.end());
}

}  // namespace

// Everything here comes from the tables the request parser uses (settings, modes, outputs,
// curves, patterns), so what is published is what is accepted.
void Service::get_capabilities(HttpRequest&, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  json modes = json::array();
  for (const auto& m : hdrd::modes()) {
    const DisplayTarget t = default_target(m.mode);
    json types = json::array();
    for (const auto& o : job::outputs())
      if (o.reply && job::applies(o, job::Source::render, m.mode)) types.push_back(o.content_type);
    json bits = json::array();
    for (int b : m.bits) bits.push_back(b);
    modes.push_back({{"name", m.name}, {"description", m.description}, {"peak_nits", t.peak_nits},
                     {"black_nits", t.black_nits}, {"paper_white_nits", t.paper_white_nits},
                     {"range", to_string(t.range)}, {"bits", t.bits}, {"allowed_bits", bits}, {"hdr", m.hdr},
                     {"default_tone_curve", tonemap::default_curve(m.mode)}, {"formats", types}});
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
  json outputs = json::array();
  for (const auto& o : job::outputs())
    outputs.push_back({{"name", o.name}, {"suffix", o.suffix}, {"content_type", o.content_type}, {"doc", o.doc},
                       {"reply", o.reply}, {"in_default_dump", o.in_default_dump}});
  json output_types = json::array();
  for (const auto& o : job::outputs())
    if (o.reply && std::find(output_types.begin(), output_types.end(), o.content_type) == output_types.end())
      output_types.push_back(o.content_type);
  output_types.push_back("application/json");
  const auto& l = cfg->limits;
  json j = {
      {"api_version", 1},
      {"settings", job::settings_json()},
      {"modes", modes},
      {"tone_curves", curves},
      {"tone_apply", choices_of("tone.apply")},
      {"exposure_modes", choices_of("exposure.mode")},
      {"gamut_mapping", choices_of("gamut")},
      {"grade", {{"placements", choices_of("grade.placement")}, {"shapers", {"pq", "log2", "sqrt", "sqrt-sqrt", "none"}}}},
      {"outputs", outputs},
      {"output_types", output_types},
      {"dump_formats", job::output_names()},
      {"scenes", shading::builtin_scene_names()},
      {"default_scene", job::find_setting("scene")->default_value()},
      {"renderer_available", scheduler_ && scheduler_->renderer_available()},
      {"limits",
       {{"max_width", l.max_width}, {"max_height", l.max_height}, {"max_pixels", l.max_pixels},
        {"max_samples", l.max_samples}, {"max_lights", l.max_lights}, {"max_body_bytes", l.max_body_bytes},
        {"max_upload_bytes", l.max_upload_bytes}, {"max_ui_bytes", l.max_ui_bytes},
        {"max_json_depth", l.max_json_depth}, {"max_request_seconds", l.max_request_seconds}}},
      {"asset_root", !cfg->paths.asset_root.empty()},
      {"dump", !cfg->paths.dump_dir.empty()},
      {"patterns", pattern_capabilities()},
      {"selftest_modes", std::vector<std::string>(mode_names().begin(), mode_names().end())},
  };
  responder->reply(json_reply(j));
}

void Service::get_displays(HttpRequest&, std::shared_ptr<Responder> responder) {
  auto overrides = display::load_default_overrides();
  const auto report = display::enumerate_displays(overrides ? *overrides : std::vector<display::ProfileOverride>{});
  json j = display::to_json(report);
  if (!overrides) j["override_error"] = overrides.error().message;
  if (auto chosen = display::choose_auto_profile(report)) j["auto"] = display::profile_to_json(*chosen);
  else j["auto"] = nullptr;
  responder->reply(json_reply(j));
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

}  // namespace hdrd::daemon

namespace hdrd::daemon {

void Service::post_render(HttpRequest& r, std::shared_ptr<Responder> responder) {
  post_frame(job::Source::render, r, std::move(responder));
}
void Service::post_encode(HttpRequest& r, std::shared_ptr<Responder> responder) {
  post_frame(job::Source::encode, r, std::move(responder));
}
void Service::post_pattern(HttpRequest& r, std::shared_ptr<Responder> responder) {
  post_frame(job::Source::pattern, r, std::move(responder));
}

}  // namespace hdrd::daemon

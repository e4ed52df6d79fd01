#include "daemon/api/support.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <thread>

#include <fmt/format.h>

#include "daemon/api/paths.hpp"

namespace hdrd::daemon {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

Reply json_reply(const nlohmann::json& j) {
  return Reply::json(200, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

std::string media_type(const HttpRequest& r) {
  const std::string* ct = r.header("content-type");
  if (!ct) return {};
  std::string t = ct->substr(0, ct->find(';'));
  t.erase(std::remove_if(t.begin(), t.end(), [](unsigned char c) { return std::isspace(c); }), t.end());
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return t;
}

std::optional<Error> check_json_post(const HttpRequest& r) {
  const std::string mt = media_type(r);
  if (!mt.empty() && mt != "application/json" && mt != "application/x-www-form-urlencoded" && mt != "text/json")
    return make_error("request.media_type",
                      fmt::format("POST {} takes a JSON body (Content-Type: application/json)", r.path.substr(0, 64)));
  if (!r.query.empty())
    return make_error("request.unknown_field",
                      fmt::format("POST {} takes no query parameters; put every option in the JSON body",
                                  r.path.substr(0, 64)),
                      r.query[0].first.substr(0, 64));
  return std::nullopt;
}

std::string generated_name(std::string_view prefix, std::uint64_t id) {
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  return fmt::format("{}-{}-{}-{}", prefix, std::chrono::duration_cast<std::chrono::milliseconds>(now).count(),
                     ::getpid(), id);
}

Clock::time_point request_deadline(const HttpRequest& r, std::optional<double> timeout_s, const Config& cfg) {
  const double limit_s = std::min(timeout_s.value_or(cfg.limits.max_request_seconds), cfg.limits.max_request_seconds);
  return deadline_after(r.started, limit_s);  // saturating: no overflow into the past
}

int encode_threads_per_job(const Config& c) {
  const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, hw / std::max(1, c.workers.encode_threads));
}

std::string canonical_key(const nlohmann::json& canonical) {
  return canonical.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

job::ParseContext daemon_context(job::Source source, job::Spelling spelling, const Config& cfg) {
  job::ParseContext ctx;
  ctx.source = source;
  ctx.spelling = spelling;
  ctx.reach = job::Reach::daemon;
  ctx.limits = cfg.limits;
  ctx.resolve_path = [root = cfg.paths.asset_root](std::string_view p, const std::string& field) {
    return resolve_in_root(root, p, field);
  };
  return ctx;
}

job::JobOptions daemon_job_options(const Config& cfg) {
  job::JobOptions jo;
  jo.threads = encode_threads_per_job(cfg);
  // Files named by a request were resolved inside the asset root; JSON scenes may not
  // reach further files (their paths are not checked against the root).
  jo.scene_files = false;
  jo.scene_base_dir = cfg.paths.asset_root.empty() ? std::filesystem::path("/nonexistent") : cfg.paths.asset_root;
  // The job holds the asset root as a directory handle and opens every file beneath it when
  // it reads it; without one (none configured, or gone) every file is refused.
  jo.files.as_given = false;
  if (!cfg.paths.asset_root.empty())
    if (auto root = io::Root::open(cfg.paths.asset_root, {.allow_hard_links = cfg.paths.allow_hard_links}); root)
      jo.files.root = *root;
  jo.max_lights = cfg.limits.max_lights;
  return jo;
}

}  // namespace hdrd::daemon

// POST /v1/cluster/submissions, GET and DELETE /v1/cluster/submissions/{id}: a sequence plan
// (`hdrd sequence plan`, docs/cluster.md) submitted to the configured Slurm cluster — the
// shards' job array and the merge job after it (deploy/slurm) — and its jobs' progress as
// Slurm reports it (daemon/cluster/slurm.hpp). The plan must lie inside the asset root; OUTBASE is a
// name in the dump directory. Without [cluster] slurm_scripts_dir: 503 cluster.unavailable.
#include <functional>
#include <mutex>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "daemon/api/support.hpp"
#include "daemon/api/paths.hpp"
#include "daemon/service.hpp"
#include "daemon/cluster/slurm.hpp"
#include "daemon/http/wire_error.hpp"

namespace hdrd::daemon {
namespace {

using nlohmann::json;
constexpr std::string_view kPrefix = "/v1/cluster/submissions/";
constexpr std::size_t kMaxSubmissions = 1000;  // remembered, oldest forgotten
// And at most this much memory held by them (a submission of scattered shards keeps one
// range per run of them): the oldest are forgotten first. GET /v1/status reports the total.
constexpr std::size_t kMaxSubmissionBytes = std::size_t{32} << 20;

std::size_t kept_bytes(const std::pair<std::string, slurm::Submission>& s) {
  return sizeof s + s.first.capacity() + s.second.shards.kept_bytes();
}

json submission_json(const std::string& id, const slurm::Submission& s) {
  return {{"id", id},
          {"array_job_id", std::to_string(s.array_job_id)},
          {"merge_job_id", std::to_string(s.merge_job_id)},
          {"array", s.shards.spec()},  // the shards as sbatch --array takes them: "0-999999", "1,4-6"
          {"shards", s.shards.size()},
          {"links", {{"self", std::string(kPrefix) + id}}}};
}

json task_json(const slurm::TaskStatus& t) {
  json j = {{"state", slurm::to_string(t.state)}, {"slurm_state", t.slurm_state}};
  if (t.array_task) j["shard"] = *t.array_task;
  if (!t.reason.empty()) j["reason"] = t.reason;
  if (!t.exit_code.empty()) j["exit_code"] = t.exit_code;
  return j;
}

bool valid_name(const std::string& n) {
  return !n.empty() && n.size() <= 100 && n[0] != '.' &&
         std::all_of(n.begin(), n.end(), [](unsigned char c) { return std::isalnum(c) || c == '.' || c == '_' || c == '-'; });
}

}  // namespace

struct Service::ClusterState {
  std::mutex mu;
  std::vector<std::pair<std::string, slurm::Submission>> submissions;  // oldest first
  std::size_t bytes = 0;                                                 // kept_bytes() over them
  void add(std::string id, slurm::Submission s) {
    std::lock_guard lock(mu);
    submissions.emplace_back(std::move(id), std::move(s));
    bytes += kept_bytes(submissions.back());
    std::size_t drop = 0;
    while (submissions.size() - drop > 1 && (submissions.size() - drop > kMaxSubmissions || bytes > kMaxSubmissionBytes))
      bytes -= kept_bytes(submissions[drop++]);
    submissions.erase(submissions.begin(), submissions.begin() + std::ptrdiff_t(drop));
  }
  std::optional<slurm::Submission> find(std::string_view id) {
    std::lock_guard lock(mu);
    for (const auto& [sid, s] : submissions)
      if (sid == id) return s;
    return std::nullopt;
  }
};

std::shared_ptr<Service::ClusterState> Service::new_cluster_state() { return std::make_shared<ClusterState>(); }

std::pair<std::size_t, std::size_t> Service::cluster_kept() const {
  std::lock_guard lock(cluster_->mu);
  return {cluster_->submissions.size(), cluster_->bytes};
}

namespace {

Result<slurm::Client> make_client(const Config& cfg) {
  if (cfg.cluster.slurm_scripts_dir.empty())
    return make_error("cluster.unavailable", "no Slurm cluster is configured ([cluster] slurm_scripts_dir)");
  slurm::ClusterConfig c;
  c.scripts_dir = cfg.cluster.slurm_scripts_dir;
  c.slurm_bin_dir = cfg.cluster.slurm_bin_dir;
  c.slurm_conf = cfg.cluster.slurm_conf;
  c.hdrd_program = cfg.cluster.hdrd_program;
  std::istringstream words(cfg.cluster.sbatch_options);
  for (std::string w; words >> w;) c.sbatch_options.push_back(w);
  c.command_timeout = std::chrono::milliseconds(cfg.cluster.command_timeout_ms);
  try {
    return slurm::Client(std::move(c));
  } catch (const HdrdError& e) {
    return make_error("cluster.unavailable", e.what());
  }
}

}  // namespace

void Service::post_cluster_submission(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  auto client = make_client(*cfg);
  if (!client) return responder->reply(Reply::error(client.error()));
  auto body = job::parse_json_object_bounded(http.body, cfg->limits);
  if (!body) return responder->reply(Reply::error(body.error()));
  for (const auto& [key, value] : body->items())
    if (key != "plan" && key != "outbase" && key != "shards" && key != "max_parallel")
      return responder->reply(Reply::error(make_error("request.unknown_field", key + ": unknown field", key)));
  if (!body->value("plan", json()).is_string())
    return responder->reply(Reply::error(make_error("request.value", "plan: the plan file (in the asset root) is required", "plan")));
  auto plan = resolve_in_root(cfg->paths.asset_root, (*body)["plan"].get<std::string>(), "plan");
  if (!plan) return responder->reply(Reply::error(plan.error()));
  const std::string name = body->value("outbase", json()).is_string() ? (*body)["outbase"].get<std::string>() : "";
  if (!valid_name(name))
    return responder->reply(Reply::error(
        make_error("request.value", "outbase: 1-100 characters of A-Z a-z 0-9 . _ -, not starting with '.'", "outbase")));
  if (cfg->paths.dump_dir.empty())
    return responder->reply(Reply::error(make_error("path.forbidden", "no dump directory is configured ([paths] dump_dir)", "outbase")));
  slurm::SubmitOptions options;
  if (body->contains("shards")) {
    const json& s = (*body)["shards"];
    if (!s.is_array() || s.size() > slurm::kMaxShards)
      return responder->reply(Reply::error(make_error("request.type", "shards: expected a list of shard indices", "shards")));
    for (const auto& i : s) {
      if (!i.is_number_unsigned() || i.get<std::uint64_t>() >= slurm::kMaxShards)
        return responder->reply(Reply::error(make_error("request.value", "shards: indices are integers >= 0", "shards")));
      options.shards.push_back(i.get<std::uint32_t>());
    }
  }
  if (body->contains("max_parallel")) {
    const json& m = (*body)["max_parallel"];
    if (!m.is_number_unsigned() || m.get<std::uint64_t>() < 1 || m.get<std::uint64_t>() > slurm::kMaxShards)
      return responder->reply(Reply::error(make_error("request.value", "max_parallel: an integer >= 1", "max_parallel")));
    options.max_parallel = m.get<std::uint32_t>();
  }
  auto submitted = client->submit(*plan, cfg->paths.dump_dir / name, options, daemon_job_options(*cfg).files);
  if (!submitted) return responder->reply(Reply::error(submitted.error()));
  const std::string id = fmt::format("slurm-{}", submitted->array_job_id);
  cluster_->add(id, *submitted);
  Reply r = json_reply(submission_json(id, *submitted));
  r.status = 202;
  r.headers.emplace_back("Location", std::string(kPrefix) + id);
  responder->reply(std::move(r));
}


namespace {

// GET and DELETE /v1/cluster/submissions/{id}: the client and the submission the path names.
struct Target {
  slurm::Client client;
  std::string id;
  slurm::Submission submission;
};

Result<Target> cluster_target(const Config& cfg, const std::string& path,
                              const std::function<std::optional<slurm::Submission>(std::string_view)>& find) {
  auto client = make_client(cfg);
  if (!client) return client.error();
  std::string id = path.substr(kPrefix.size());
  const auto sub = find(id);
  if (!sub) return make_error("cluster.not_found", fmt::format("no cluster submission {}", id.substr(0, 64)));
  return Target{std::move(*client), std::move(id), *sub};
}

}  // namespace

void Service::get_cluster_submission(HttpRequest& http, std::shared_ptr<Responder> responder) {
  auto t = cluster_target(*config(), http.path, [this](std::string_view id) { return cluster_->find(id); });
  if (!t) return responder->reply(Reply::error(t.error()));
  auto p = t->client.progress(t->submission);
  if (!p) return responder->reply(Reply::error(p.error()));
  json shards = json::array();
  for (const auto& task : p->shards) shards.push_back(task_json(task));
  json j = submission_json(t->id, t->submission);
  j["state"] = slurm::to_string(p->state);
  j["counts"] = {{"pending", p->pending}, {"running", p->running}, {"completed", p->completed},
                 {"failed", p->failed}, {"cancelled", p->cancelled}};
  j["shard_states"] = shards;
  j["unknown_shards"] = p->unknown_shards;
  j["merge"] = p->merge ? task_json(*p->merge) : json();
  responder->reply(json_reply(j));
}

void Service::delete_cluster_submission(HttpRequest& http, std::shared_ptr<Responder> responder) {
  auto t = cluster_target(*config(), http.path, [this](std::string_view id) { return cluster_->find(id); });
  if (!t) return responder->reply(Reply::error(t.error()));
  if (auto ok = t->client.cancel(t->submission); !ok) return responder->reply(Reply::error(ok.error()));
  json j = submission_json(t->id, t->submission);
  j["state"] = "cancelled";
  responder->reply(json_reply(j));
}

}  // namespace hdrd::daemon

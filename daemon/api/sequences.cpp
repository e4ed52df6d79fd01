// POST /v1/sequences and /v1/jobs: the daemon's transport for job::run_sequence
// (job/sequence.hpp). The request is a render or encode request plus the settings marked
// `sequence`, parsed by the same parser as `hdrd render --frames` / `hdrd encode 'shot.%04d.exr'`
// and checked as far as it can be without a frame (job::check_request) before it is
// answered 202; the job then runs in the registry (jobs.hpp) and its files go into the
// dump directory as DUMP_DIR/NAME*.
#include <fcntl.h>
#include <sys/stat.h>

#include <fmt/format.h>

#include "daemon/api/support.hpp"
#include "daemon/jobs/jobs.hpp"
#include "daemon/jobs/memory.hpp"
#include "daemon/api/paths.hpp"
#include "daemon/service.hpp"

namespace hdrd::daemon {

using nlohmann::json;

namespace {

constexpr std::string_view kJobsPrefix = "/v1/jobs/";

// `source` when given, else encode when `images` is, else render; `source` is the
// endpoint's, not a setting, so it leaves the body here.
Result<job::Source> sequence_source(json& body) {
  if (auto it = body.find("source"); it != body.end()) {
    const json v = *it;
    body.erase(it);
    if (v == "render") return job::Source::render;
    if (v == "encode") return job::Source::encode;
    return make_error("request.value", fmt::format("source: must be \"render\" or \"encode\", not {}", v.dump().substr(0, 64)),
                      "source");
  }
  return body.contains("images") ? job::Source::encode : job::Source::render;
}

// The sequence's parse context: `images` (a pattern, a directory, a list file) resolves
// inside the asset root as a directory would; every other path as a file.
job::ParseContext sequence_context(job::Source source, const Config& cfg) {
  job::ParseContext ctx = daemon_context(source, job::Spelling::json, cfg);
  ctx.sequence = true;
  ctx.resolve_path = [root = cfg.paths.asset_root](std::string_view p, const std::string& field) {
    return field == "images" ? resolve_sequence_in_root(root, p, field) : resolve_in_root(root, p, field);
  };
  return ctx;
}

Reply job_reply(unsigned status, const JobInfo& info) {
  Reply r = Reply::json(status, info.to_json().dump(2, ' ', false, json::error_handler_t::replace) + "\n");
  return r;
}

std::string_view video_content_type(const std::string& path) {
  if (path.size() >= 4 && path.compare(path.size() - 4, 4, ".mkv") == 0) return "video/x-matroska";
  return "video/mp4";
}

// A finished job's file as the reply body, streamed from its descriptor: opened in the dump
// directory without following a link, and only while it is the file the job wrote (its
// device, inode and size as recorded when the job finished); anything else is 410.
Result<Reply> file_reply(const JobInfo& info, const std::string& kind, std::string content_type) {
  const auto path = info.files.count(kind) ? std::filesystem::path(info.files.at(kind)) : std::filesystem::path();
  const std::string name = path.filename().string();
  const auto recorded = info.identities.find(kind);
  if (path.empty() || recorded == info.identities.end())
    return make_error("job.gone", fmt::format("job {} has no {} file", info.id, kind));
  auto dir = io::Root::open(path.parent_path(), {.allow_hard_links = true, .what = "the dump directory"});
  auto fd = dir ? io::open_beneath(**dir, name) : Result<io::UniqueFd>(dir.error());
  if (!fd && fd.error().code == "path.not_found")
    return make_error("job.gone", fmt::format("{} is no longer in the dump directory", name));
  if (!fd)
    return make_error("job.file_changed", fmt::format("{} is not the file job {} wrote: {}", name, info.id, fd.error().message));
  auto now = io::identity_of(fd->get(), name);
  if (!now) return now.error();
  if (!(*now == recorded->second))
    return make_error("job.file_changed",
                      fmt::format("{} is not the file job {} wrote (replaced since: another device, inode or size)", name, info.id));
  Reply r;
  r.content_type = std::move(content_type);
  r.file = std::make_shared<const FileBody>(fd->release(), static_cast<std::uint64_t>(now->size));
  r.headers.emplace_back("Content-Disposition", fmt::format("attachment; filename=\"{}\"", name));
  return r;
}

Error not_found(std::string_view id) {
  return make_error("job.not_found", fmt::format("no job '{}' (finished jobs are forgotten after [sequences] history)",
                                                 one_line(id.substr(0, 64))));
}

}  // namespace

void Service::post_sequences(HttpRequest& http, std::shared_ptr<Responder> responder) {
  if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  const auto cfg = config();
  auto body = job::parse_json_object_bounded(http.body, cfg->limits);
  if (!body) return responder->reply(Reply::error(body.error()));
  auto source = sequence_source(*body);
  if (!source) return responder->reply(Reply::error(source.error()));
  // A sequence is always a dump: its files go into the dump directory (`formats` are its dumps').
  if (auto it = body->find("dump"); it != body->end() && *it == false)
    return responder->reply(Reply::error(make_error(
        "request.value", "dump: a sequence always writes into the dump directory (its result is GET /v1/jobs/{id}/result)",
        "dump")));
  (*body)["dump"] = true;
  auto request = job::parse_request_json(*body, sequence_context(*source, *cfg));
  if (!request) return responder->reply(Reply::error(request.error()));
  if (cfg->paths.dump_dir.empty())
    return responder->reply(
        Reply::error(make_error("path.forbidden", "no dump directory is configured ([paths] dump_dir)", "dump")));
  const job::JobOptions jo = daemon_job_options(*cfg);
  auto plan = job::check_request(*request, jo);
  if (!plan) return responder->reply(Reply::error(plan.error()));
  if (*source == job::Source::encode)  // a link in the pattern's directory, a list naming anything
    if (auto ok = check_files_in_root(cfg->paths.asset_root, plan->inputs, "images"); !ok)
      return responder->reply(Reply::error(ok.error()));
  constexpr std::size_t kQueueDepth = 2;  // job::SequenceOptions::queue_depth
  auto memory = estimate_sequence_memory(*request, jo.files, plan->inputs.empty() ? std::filesystem::path() : plan->inputs.front(),
                                         kQueueDepth, http.body.size(), cfg->limits, plan->frames);
  if (!memory) return responder->reply(Reply::error(memory.error()));

  SequenceSpec spec;
  spec.name = request->text("name").empty() ? generated_name("sequence", http.id) : request->text("name");
  spec.outbase = cfg->paths.dump_dir / spec.name;
  spec.frames_total = plan->frames;
  spec.memory_bytes = *memory;
  spec.options = jo;
  spec.timeout_s = request->optional_number("timeout_s");
  spec.request = std::move(*request);
  auto info = jobs_->submit(std::move(spec));
  if (!info) {
    Reply r = Reply::error(info.error());
    if (info.error().code.rfind("queue.", 0) == 0) r.headers.emplace_back("Retry-After", std::to_string(cfg->workers.retry_after_s));
    return responder->reply(std::move(r));
  }
  const json full = info->to_json();
  json j = {{"id", info->id}, {"name", info->name}, {"state", to_string(info->state)},
            {"frames_total", info->frames_total}, {"memory_estimate_bytes", info->memory_bytes}, {"links", full["links"]}};
  Reply r = Reply::json(202, j.dump(2) + "\n");
  r.headers.emplace_back("Location", "/v1/jobs/" + info->id);
  responder->reply(std::move(r));
}

void Service::get_jobs(HttpRequest&, std::shared_ptr<Responder> responder) {
  json list = json::array();
  for (const auto& j : jobs_->list()) list.push_back(j.to_json());
  const auto s = jobs_->stats();
  responder->reply(json_reply({{"jobs", list},
                               {"queued", s.queued},
                               {"running", s.running},
                               {"finished", s.finished},
                               {"memory_in_flight_bytes", s.memory_in_flight_bytes},
                               {"memory_kept_bytes", s.memory_kept_bytes}}));
}

// GET /v1/jobs/{id}, /v1/jobs/{id}/result, /v1/jobs/{id}/sidecar.
void Service::get_job(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const std::string_view rest = std::string_view(http.path).substr(kJobsPrefix.size());
  const auto slash = rest.find('/');
  const std::string_view id = rest.substr(0, slash);
  const std::string_view part = slash == std::string_view::npos ? std::string_view() : rest.substr(slash + 1);
  if (!part.empty() && part != "result" && part != "sidecar")
    return responder->reply(Reply::error(make_error("request.not_found", fmt::format("no endpoint {}", http.path.substr(0, 200)))));
  auto info = jobs_->get(id);
  if (!info) return responder->reply(Reply::error(not_found(id)));
  if (part.empty()) return responder->reply(job_reply(200, *info));
  if (info->state != JobState::done) {
    Reply r = Reply::error(make_error(
        info->state == JobState::queued || info->state == JobState::running ? "job.not_ready" : "job.gone",
        fmt::format("job {} is {}{}", info->id, to_string(info->state),
                    info->error ? ": " + info->error->message : std::string(", frame ") + std::to_string(info->frames_done) +
                                                                    " of " + std::to_string(info->frames_total))));
    if (!is_final(info->state)) r.headers.emplace_back("Retry-After", "1");
    return responder->reply(std::move(r));
  }
  if (info->files_removed || !info->superseded_by.empty())
    return responder->reply(Reply::error(make_error(
        "job.gone", info->files_removed ? fmt::format("job {}'s files were deleted", info->id)
                                        : fmt::format("job {}'s files were overwritten by job {}", info->id, info->superseded_by))));
  const bool video = part == "result" && info->files.count("video");
  auto r = video ? file_reply(*info, "video", std::string(video_content_type(info->files.at("video"))))
                 : file_reply(*info, "sidecar", "application/json");
  responder->reply(r ? std::move(*r) : Reply::error(r.error()));
}

void Service::delete_job(HttpRequest& http, std::shared_ptr<Responder> responder) {
  const std::string id = http.path.substr(kJobsPrefix.size());
  if (id.find('/') != std::string::npos)
    return responder->reply(Reply::error(make_error("request.method", "DELETE takes /v1/jobs/{id}")));
  jobs_->remove(id, [responder, id](std::optional<Result<JobInfo>> done) {
    if (!done) return responder->reply(Reply::error(not_found(id)));
    if (!*done) return responder->reply(Reply::error(done->error()));
    responder->reply(job_reply(200, **done));
  });
}

}  // namespace hdrd::daemon

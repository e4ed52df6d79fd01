// POST /v1/render, /v1/encode, /v1/pattern: the daemon's transport for the one frame job
// (job/frame_job.hpp). The request is parsed by the same parser as the CLI's flags, the
// job is the same; only where the request comes from (a JSON body, query parameters, a
// multipart upload) and where the outputs go (the reply body, or the dump directory)
// are the daemon's.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "daemon/http/accept.hpp"
#include "daemon/api/support.hpp"
#include "daemon/api/frame_reply.hpp"
#include "daemon/http/input_bounds.hpp"
#include "daemon/jobs/memory.hpp"
#include "daemon/api/paths.hpp"
#include "daemon/jobs/render_worker.hpp"
#include "daemon/service.hpp"
#include "encode/io/digest.hpp"
#include "job/frame_job.hpp"

namespace hdrd::daemon {

using nlohmann::json;

namespace {

// The options of a POST /v1/encode: the JSON part of a multipart body, or the query
// string of a raw EXR body. The EXR is moved into `exr`.
Result<json> encode_options(HttpRequest& http, const Config& cfg, std::string& exr, job::Spelling& spelling) {
  if (http.multipart) {
    if (!http.query.empty())
      return make_error("request.conflict",
                        "multipart uploads carry their options in the 'request' part, not the query string",
                        http.query[0].first.substr(0, 64));
    auto upload = split_encode_upload(http.parts, cfg.limits);  // input_bounds.hpp: the bounded JSON part
    if (!upload) return upload.error();
    exr = std::move(upload->exr);
    return std::move(upload->options);
  }
  const std::string mt = media_type(http);
  if (mt != "image/x-exr" && mt != "application/octet-stream" && mt != "image/aces")
    return make_error("request.media_type",
                      "POST /v1/encode takes an OpenEXR body (Content-Type: image/x-exr) or multipart/form-data");
  spelling = job::Spelling::query;
  auto q = job::query_to_request_json(http.query);
  if (!q) return q.error();
  exr = std::move(http.body);
  return std::move(*q);
}

struct FrameJobState {
  std::unique_ptr<job::FrameJob> job;
  std::optional<job::Output> reply;  // the body's format; unset: a dump
  std::string dump_name;
  std::shared_ptr<const Config> config;
  Metrics* metrics = nullptr;
};

std::string_view prefix_of(job::Source s) { return job::to_string(s); }

Result<std::uint64_t> memory_estimate(const job::FrameJob& job, const io::InputFiles& files, std::optional<job::Output> reply,
                                      std::size_t body_bytes, std::string_view exr, const job::Limits& limits) {
  const job::FrameRequest& r = job.request();
  switch (r.source) {
    case job::Source::render: return estimate_render_memory(r, files, reply, body_bytes, limits);
    case job::Source::encode:
      return estimate_encode_memory(r, files, reply, {reinterpret_cast<const std::uint8_t*>(exr.data()), exr.size()}, limits);
    case job::Source::pattern: return estimate_pattern_memory(r, reply, body_bytes);
  }
  return make_error("internal", "unknown request source");
}

}  // namespace

void Service::post_frame(job::Source source, HttpRequest& http, std::shared_ptr<Responder> responder) {
  const auto cfg = config();
  json options;
  std::string exr;
  job::Spelling spelling = job::Spelling::json;
  if (source == job::Source::encode) {
    auto o = encode_options(http, *cfg, exr, spelling);
    if (!o) return responder->reply(Reply::error(o.error()));
    options = std::move(*o);
    if (exr.empty()) return responder->reply(Reply::error(make_error("request.value", "empty EXR upload", "image")));
  } else {
    if (auto bad = check_json_post(http)) return responder->reply(Reply::error(*bad));
  }
  const auto ctx = daemon_context(source, spelling, *cfg);
  auto request = source == job::Source::encode ? job::parse_request_json(options, ctx) : job::parse_request(http.body, ctx);
  if (!request) return responder->reply(Reply::error(request.error()));
  const bool dump = request->boolean("dump");
  const std::string name = request->text("name");
  const std::optional<double> timeout_s = request->optional_number("timeout_s");
  const std::string key = canonical_key(request->canonical());

  job::JobOptions jo = daemon_job_options(*cfg);
  // The upload's identity for coalescing, before its bytes move into the job (no copy).
  const std::string upload_key = exr.empty() ? "" : fmt::format("|exr:{}:{}", exr.size(), io::content_digest(exr));
  job::EncodeInput input;
  if (source == job::Source::encode) {
    input.bytes = std::move(exr);
    input.name = "upload";
  }
  auto st = std::make_shared<FrameJobState>();
  auto made = job::FrameJob::create(std::move(*request), jo, std::move(input));
  if (!made) return responder->reply(Reply::error(made.error()));
  st->job = std::move(*made);
  if (!dump) {
    auto output = negotiate_output(http.header("accept"), st->job->target().mode, st->job->request().source);
    if (!output) return responder->reply(Reply::error(output.error()));
    if (auto ok = st->job->set_outputs({*output}); !ok) return responder->reply(Reply::error(ok.error()));
    st->reply = *output;
  } else {
    if (auto ok = accepts_json(http.header("accept")); !ok) return responder->reply(Reply::error(ok.error()));
    if (cfg->paths.dump_dir.empty())
      return responder->reply(Reply::error(make_error("path.forbidden", "no dump directory is configured ([paths] dump_dir)", "dump")));
  }
  st->config = cfg;
  st->metrics = &metrics_;
  st->dump_name = name.empty() ? generated_name(prefix_of(source), http.id) : name;

  JobSpec spec;
  spec.deadline = request_deadline(http, timeout_s, *cfg);
  // What the job will allocate at its peak, checked against the budget at admission (memory.hpp).
  auto memory = memory_estimate(*st->job, jo.files, st->reply, http.body.size(), st->job->input().bytes, cfg->limits);
  if (!memory) return responder->reply(Reply::error(memory.error()));
  spec.memory_bytes = *memory;
  if (!dump)
    spec.key = key + "|" + std::string(job::output_info(*st->reply).content_type) + upload_key;
  const bool renders = st->job->needs_renderer();
  if (renders) {
    spec.render = [st](RenderResource* res, const JobControl& control) -> Result<void> {
      auto* rr = dynamic_cast<RendererResource*>(res);
      if (!rr) return make_error("renderer.unavailable", "renderer not available on this worker");
      st->job->set_stop([&control] { return control.should_stop(); });
      auto ok = st->job->render(*rr->renderer);
      st->job->set_stop({});
      return ok;
    };
  }
  spec.finish = [st](const JobControl& control) {
    st->job->set_stop([&control] { return control.should_stop(); });
    auto result = st->job->finish();
    st->job->set_stop({});
    if (!result) return Reply::error(result.error());
    for (const auto& [stage, ms] : result->timings_ms.items())
      if (stage == "render" || stage == "encode" || stage == "outputs")
        st->metrics->stage_time(stage == "outputs" ? "serialize" : stage, ms.get<double>() / 1e3);
    auto reply = st->reply ? frame_reply(*result, *st->reply)
                           : dump_reply(*result, st->config->paths.dump_dir, st->dump_name);
    return reply ? std::move(*reply) : Reply::error(reply.error());
  };
  submit(std::move(spec), renders, responder);
}

}  // namespace hdrd::daemon

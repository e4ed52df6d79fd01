// hdrd sequence plan | run | merge: a sequence in shards that run anywhere (a Slurm job
// array, a Kubernetes Indexed Job: deploy/, docs/cluster.md) and merge into what one
// `hdrd render/encode` process makes (job/sequence_plan.hpp).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/video/writer.hpp"
#include "job/sequence_plan.hpp"
#include "tools/common/progress_bar.hpp"
#include "tools/hdrd/command.hpp"
#include "tools/hdrd/frame_args.hpp"

namespace hdrd::cli {
namespace {

struct PlanCommand {
  CommonOptions common;
  int shards = 0;
  std::string plan;
};
struct RunCommand {
  CommonOptions common;
  std::string plan;
  int shard = -1;
};
struct MergeCommand {
  CommonOptions common;
  std::string plan, outbase;
};

job::SequenceOptions options_with_bar(ProgressBar& bar) {
  job::SequenceOptions o;
  o.progress = [&bar](const job::SequenceProgress& p) { bar.update(p.frames_done, p.frames_total, p.fps, p.eta_s); };
  return o;
}

void plan(const PlanCommand& o, const std::vector<std::string>& frame_args) {
  set_progress_enabled(!o.common.quiet);
  if (frame_args.empty()) throw CliError("sequence plan: the sequence is missing: render ... or encode INPUT ...");
  const FrameArgs args = parse_frame_args(frame_args);
  video::quiet_codec_logs();
  ProgressBar bar("hdrd: analysis", progress_enabled());
  auto made = job::make_sequence_plan(args.request, args.source, o.shards, o.plan, options_with_bar(bar));
  bar.finish();
  if (!made) throw HdrdError(made.error());
  if (auto ok = job::write_sequence_plan(*made); !ok) throw HdrdError(ok.error());
  if (o.common.json) {
    nlohmann::json j = made->to_json();
    j.erase("track");
    j.erase("request");
    j["plan"] = o.plan;
    return print_out(j.dump(2));
  }
  std::string s = fmt::format("{}: {} frames in {} shards, work dir {}\n", o.plan, made->frames, made->shards,
                              made->resolved_work_dir().string());
  for (std::size_t i = 0; i < made->ranges.size(); ++i)
    s += fmt::format("  shard {}: frames {}..{}\n", i, made->ranges[i].first,
                     made->ranges[i].first + made->ranges[i].second - 1);
  print_out(s);
}

void run(const RunCommand& o) {
  set_progress_enabled(!o.common.quiet);
  auto p = job::read_sequence_plan(o.plan);
  if (!p) throw HdrdError(p.error());
  video::quiet_codec_logs();
  ProgressBar bar(fmt::format("hdrd: shard {}", o.shard), progress_enabled());
  auto r = job::run_sequence_shard(*p, o.shard, options_with_bar(bar));
  bar.finish();
  if (!r) throw HdrdError(r.error());
  if (o.common.json) return print_out(nlohmann::json{{"shard", o.shard}, {"frames", r->frames}, {"files", r->files}}.dump(2));
  std::string s = fmt::format("shard {} of {}: {} frames\n", o.shard, p->shards, r->frames);
  for (const auto& [kind, path] : r->files) s += fmt::format("  {:8} {}\n", kind, path);
  print_out(s);
}

void merge(const MergeCommand& o) {
  set_progress_enabled(!o.common.quiet);
  auto p = job::read_sequence_plan(o.plan);
  if (!p) throw HdrdError(p.error());
  video::quiet_codec_logs();
  auto r = job::merge_sequence_plan(*p, o.outbase);
  if (!r) throw HdrdError(r.error());
  if (o.common.json) return print_out(r->sidecar.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
  std::string s = fmt::format("merged {} shards: {} frames\n", p->shards, r->frames);
  for (const auto& [kind, path] : r->files) s += fmt::format("  {:12} {}\n", kind, path);
  print_out(s);
}

void setup(CLI::App& root) {
  auto* seq = root.add_subcommand("sequence", "Split a sequence into shards for a cluster, run one, merge them");
  seq->require_subcommand(1);
  seq->footer(
      "Examples:\n"
      "  hdrd sequence plan --shards 8 -o /shared/shot.json encode '/shared/shot.%04d.exr' --video hevc\n"
      "  hdrd sequence plan --shards 4 -o plan.json render --scene hdr --frames 240 --video hevc\n"
      "  hdrd sequence run /shared/shot.json --shard 3          (on any machine; idempotent)\n"
      "  hdrd sequence merge /shared/shot.json -o /shared/out/shot\n"
      "The merged result equals one `hdrd render/encode` process with the same options (docs/cluster.md);\n"
      "deploy/slurm/submit.sh and deploy/k8s/render.sh run the shards and the merge on Slurm and Kubernetes.");

  auto po = std::make_shared<PlanCommand>();
  auto* p = seq->add_subcommand("plan", "Analyse the sequence (metering, cuts, peaks) and write the plan");
  p->add_option("--shards", po->shards, "Number of shards")->required()->check(CLI::Range(1, 1000000));
  p->add_option("-o,--output", po->plan, "The plan file (its work dir: PLAN.json.d beside it)")->required();
  add_common_options(*p, po->common);
  p->prefix_command();  // `render ...` / `encode INPUT ...` follow, with their own options
  p->footer("The sequence follows the options: render ... or encode INPUT ..., as `hdrd render` / `hdrd encode` take it.");
  p->callback([po, p] { plan(*po, p->remaining()); });

  auto ro = std::make_shared<RunCommand>();
  auto* r = seq->add_subcommand("run", "Make one shard's frames and video segment into the plan's work dir");
  r->add_option("plan", ro->plan, "The plan file")->required();
  r->add_option("--shard", ro->shard, "The shard, 0 .. shards-1 (Slurm: $SLURM_ARRAY_TASK_ID; Kubernetes: "
                                      "$JOB_COMPLETION_INDEX)")
      ->required();
  add_common_options(*r, ro->common);
  r->callback([ro] { run(*ro); });

  auto mo = std::make_shared<MergeCommand>();
  auto* m = seq->add_subcommand("merge", "Join every shard into OUTBASE.mp4, the metadata and the sidecar");
  m->add_option("plan", mo->plan, "The plan file")->required();
  m->add_option("-o,--output", mo->outbase, "Output base: OUTBASE.mp4, OUTBASE.json, ...")->required();
  add_common_options(*m, mo->common);
  m->callback([mo] { merge(*mo); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("sequence", 22, hdrd::cli::setup)

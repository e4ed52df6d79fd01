// A sequence split into shards that run anywhere and merge into what one process makes
// (docs/cluster.md): `hdrd sequence plan | run | merge`, driven by Slurm job arrays or
// Kubernetes Indexed Jobs (deploy/).
//
// The time axis carries state from frame to frame (adaptation, scene cuts, the detected
// peak), so shards cannot decide their frames alone. The plan runs the analysis pass
// (analyse_sequence: every frame metered and decided as a one-process run decides it) and
// writes the decisions for every frame — the track — with the frame ranges. A shard reads
// its decisions from the track and measures nothing across its boundaries, so a frame's
// result does not depend on which shard made it; the merge pools the shards' per-frame light
// into the sequence's metadata (MaxCLL/MaxFALL, HDR10+, DV) and joins their video segments
// without re-encoding. Shards keep no state: a retried shard writes the same bytes.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/result.hpp"
#include "encode/tone/temporal.hpp"
#include "job/request.hpp"
#include "job/sequence.hpp"

namespace hdrd::job {

struct SequencePlan {
  int shards = 1;
  int frames = 0;
  std::filesystem::path work_dir;                   // as written (relative: to the plan's folder)
  std::filesystem::path plan_path;                  // where it was read from or written to
  Source source = Source::render;
  nlohmann::json request;                           // the sequence request, paths absolute
  std::vector<temporal::FrameDecision> track;       // one decision per frame
  std::vector<std::pair<int, int>> ranges;          // per shard: first frame, frame count
  std::string fingerprint;                          // of request, track, ranges, work_dir and source

  std::filesystem::path resolved_work_dir() const;  // work_dir against the plan's folder
  nlohmann::json to_json() const;
};

// Parses the request (a sequence), runs the analysis pass and splits the frames into
// `shards` ranges of nearly equal length (shard i: frames [i F / N, (i + 1) F / N)). Paths in
// the request become absolute, so that shards elsewhere read the same files.
Result<SequencePlan> make_sequence_plan(const nlohmann::json& request, Source source, int shards,
                                        const std::filesystem::path& plan_path, const SequenceOptions& options);

// The plan file: written atomically; read back with every field checked (sequence.plan).
Result<void> write_sequence_plan(const SequencePlan& plan);
Result<SequencePlan> read_sequence_plan(const std::filesystem::path& plan_path);

// The plan's request, parsed as the plan parsed it.
Result<FrameRequest> plan_request(const SequencePlan& plan);

// One shard: its frames into the work dir (shard-I.segment, frames/, shard-I.json, then
// shard-I.done). The merge of every shard's output into OUTBASE*.
Result<SequenceResult> run_sequence_shard(const SequencePlan& plan, int shard, SequenceOptions options);
Result<SequenceResult> merge_sequence_plan(const SequencePlan& plan, const std::filesystem::path& outbase);

}  // namespace hdrd::job

// A sequence: the frame job (job/frame_job.hpp) run once per frame along a time axis, with
// the decisions that need the frames before it (encode/tone/temporal.hpp: scene cuts,
// exposure adaptation, dynamic source peak), the metadata measured from all of them
// (encode/video/sequence_metadata.hpp: MaxCLL/MaxFALL, HDR10+, Dolby Vision L1), and
// the sequence's outputs: a video file (encode/video/writer.hpp), per-frame dumps
// OUTBASE.NNNNN.EXT with their sidecars, OUTBASE.hdr10plus.json, OUTBASE.dovi.json and the
// sequence sidecar OUTBASE.json (docs/sequences.md). hdrd render/encode with --frames or
// a frame pattern, POST /v1/sequences and hdrctl sequence all run this.
//
// Frames stream: the job renders and encodes frame n on the caller's thread (the GL
// context's) while a writer thread writes frame n-1's dumps and feeds the video encoder;
// between them a bounded queue (SequenceOptions::queue_depth frames), so resident memory
// does not grow with the number of frames. An error, or cancellation, removes every file
// the sequence wrote: a sequence is all or nothing.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/frame.hpp"
#include "encode/result.hpp"
#include "encode/tone/temporal.hpp"
#include "job/frame_job.hpp"
#include "job/request.hpp"

namespace hdrd::job {

// The EXR files of a sequence, in order: a printf pattern ("shot.%04d.exr": every number
// that exists, from the lowest, consecutive: a gap is an error naming the missing frame),
// a directory (its *.exr files in name order), or a list file (one path per line, relative
// to the list's directory; blank lines and '#' comments skipped). Errors: input.sequence.
// `files`: where a list file is opened (JobOptions::files).
Result<std::vector<std::filesystem::path>> exr_sequence_files(const std::filesystem::path& spec,
                                                              const io::InputFiles& files = {});
// True for what only a sequence can be: a printf pattern, a directory, a list file (.txt, .lst).
bool names_a_sequence(const std::filesystem::path& spec);
// True when the request JSON sets any setting marked `sequence` (job/settings.hpp).
bool sets_sequence_settings(const nlohmann::json& request);

struct SequenceProgress {
  int frames_done = 0;
  int frames_total = 0;
  double elapsed_s = 0;
  double fps = 0;    // frames done per second so far
  double eta_s = 0;  // time left at that rate
};

// One shard of a planned sequence (job/sequence_plan.hpp, docs/cluster.md): its frames,
// decided by the plan's track instead of in line, so that a frame's result does not depend
// on which shard made it.
struct ShardSpec {
  int shard = 0;
  int first_frame = 0, frame_count = 0;
  int scenes_before = 0;                                        // scenes started before first_frame
  const std::vector<temporal::FrameDecision>* track = nullptr;  // every frame of the sequence
  std::filesystem::path work_dir;                               // shard-I.segment/.json/.done, frames/
  std::string fingerprint;                                      // the plan's
};

struct SequenceOptions {
  JobOptions job;                 // threads, scene files, cancellation (should_stop)
  // A shard: the writer stage writes its video segment, the frames' dumps and statistics
  // into the work dir (shard-I.segment, frames/frame.NNNNN.EXT, shard-I.json, then
  // shard-I.done) instead of the sequence's outputs.
  std::optional<ShardSpec> shard;
  // After every frame written, on the writer thread (the CLI's bar, the daemon's job state).
  std::function<void(const SequenceProgress&)> progress;
  // Live output (hdrd render --present): every encoded frame in order, on the writer
  // thread, after its dumps; an error stops the sequence.
  std::function<Result<void>(const EncodedFrame& frame, int index)> on_frame;
  std::size_t queue_depth = 2;    // frames between the render/encode stage and the writer
};

struct SequenceResult {
  nlohmann::json sidecar;                      // OUTBASE.json as written
  std::map<std::string, std::string> files;    // kind -> path: video, sidecar, hdr10plus, dovi, frames (a pattern)
  int frames = 0;
  std::vector<std::string> warnings;
  nlohmann::json timings_ms = nlohmann::json::object();  // totals per stage
};

// The time axis a sequence request asks for (encode/tone/temporal.hpp): adaptation (both
// directions from exposure.adaptation_time_s when given, a direction given itself wins,
// else each direction's default), scene cuts, the dynamic peak.
temporal::TemporalSettings temporal_settings(const FrameRequest& request);

// Runs a sequence request (FrameRequest::sequence, source render or encode) into OUTBASE*.
// `renderer`: the render requests' (made here when null). The EXR frames come from the
// request's `images` setting.
Result<SequenceResult> run_sequence(const FrameRequest& request, const std::filesystem::path& outbase,
                                    const SequenceOptions& options, shading::Renderer* renderer = nullptr);

// What run_sequence refuses before its first frame, checked without rendering or encoding
// one: the EXR files and the frame count, the temporal and video settings, the video
// against the first frame's display target (H.264 is SDR only, scRGB has no video form) and
// the frame size (4:2:0 needs an even size; an encode's size is its first EXR's, from the
// header). The daemon answers 4xx from it before 202.
struct SequenceCheck {
  int frames = 0;                             // 0: a render's animation decides (known at its frame 0)
  std::vector<std::filesystem::path> inputs;  // an encode's EXR files, `frames` of them
  DisplayTarget target;                       // the first frame's
};
Result<SequenceCheck> check_sequence(const FrameRequest& request, const JobOptions& options = {});

// What a front end checks before any work, the same for every front end (issue 28.7 and
// 29.13): the output base's directory (the CLI's -o: it exists and can be written), an
// inline scene (parsed and validated as the renderer will), and for a sequence
// check_sequence. The daemon runs it before its 202, the CLI before its first frame; an
// error's message leads with the setting it is about, as `spelling` names it (--width/--height,
// --video, -o ...), never with a frame.
struct CheckOptions {
  std::filesystem::path outbase;       // empty: not checked (the daemon's dump directory is checked at start)
  Spelling spelling = Spelling::json;
};
Result<SequenceCheck> check_request(const FrameRequest& request, const JobOptions& options = {},
                                    const CheckOptions& check = {});
// dump.path (field "output") naming what is wrong with OUTBASE: no file name, no such
// directory, not a directory, not writable.
Result<void> check_output_base(const std::filesystem::path& outbase);
// A render's inline scene (request `scene` as a JSON object): scene.* errors, field scene.PATH.
Result<void> check_inline_scene(const FrameRequest& request, const JobOptions& options = {});

// The analysis pass of a planned sequence: every frame metered and decided exactly as
// run_sequence decides it in line (each frame's job stops once it is decided: no encode,
// no outputs). A render is rendered (its metering is the rendered frame's); an EXR is read.
Result<std::vector<temporal::FrameDecision>> analyse_sequence(const FrameRequest& request,
                                                              const SequenceOptions& options,
                                                              shading::Renderer* renderer = nullptr);

// Joins the shards' statistics (shard-I.json, in order), segments and frames into the
// sequence's outputs at OUTBASE, as run_sequence writes them. Refuses a shard of another
// plan (fingerprint), a gap or overlap, or a missing file, naming the shard.
Result<SequenceResult> merge_sequence_shards(const FrameRequest& request,
                                             const std::vector<std::filesystem::path>& shard_stats,
                                             const std::string& fingerprint, const std::filesystem::path& outbase);

}  // namespace hdrd::job

// The one frame job behind every front end (hdrd render / encode / pattern, POST
// /v1/render / encode / pattern, hdrctl, the Python client): source (scene, EXR, pattern)
// -> render (a scene) -> meter -> encode on the GPU or the CPU -> outputs (reply body,
// dump files, sidecar). Every default and every rule is decided here once; the CLI and the
// daemon differ only in transport (how the request arrives, where the outputs go).
//
// The job has two stages so that the daemon can run them on different threads: render()
// needs a renderer (a GL context; render requests only), finish() runs anywhere.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/frame.hpp"
#include "encode/image.hpp"
#include "encode/io/beneath.hpp"
#include "encode/pipeline.hpp"
#include "encode/result.hpp"
#include "job/outputs.hpp"
#include "job/request.hpp"
#include "shading/gl_context.hpp"

namespace hdrd::shading {
class Renderer;
}

namespace hdrd::job {

// What the source says about the frame's place in time (a render's scene animation).
struct FrameFacts {
  bool scene_cut = false;  // the scene keys a cut at this frame
  double duration_s = 0;   // the scene's animation length (0: a still scene)
};

// What the front end provides beyond the request.
// What a request loads from files (job/build.cpp encode_settings), kept between the frames
// of a sequence. Filled by the first frame; the frames of one sequence run one at a time.
struct LoadedResources {
  bool loaded = false;
  UiSettings ui;
  std::shared_ptr<const grade::Grade> grade;
  std::vector<std::string> warnings;  // the loading's warnings, repeated for every frame
};

struct JobOptions {
  int threads = 0;                          // encoder threads (0: all cores)
  // JSON scenes resolve their relative file names here; `scene_files` false confines a
  // scene to the file it was named by (the daemon: requests name files only in the root).
  std::filesystem::path scene_base_dir = ".";
  bool scene_files = true;
  // Where every file the request names is opened, at the moment it is read (frames, LUTs,
  // EDIDs, maps, UI PNGs, scenes; encode/io/beneath.hpp): the daemon's asset root, held by
  // the job as a directory handle; none (the CLI): as given. The resolved paths in the
  // request are only names within it: nothing is read by path unchecked.
  io::InputFiles files;
  int max_lights = 256;
  std::function<bool()> should_stop;        // cancellation (the daemon's deadline, a disconnect)
  // Sequences (job/sequence.cpp): the scene time of a render, and the per-frame decisions
  // taken once the frame is metered and its pipeline prepared, before it is encoded (the
  // exposure scale, the source peak: encode/pipeline.hpp set_exposure_scale/set_source_peak).
  std::optional<double> time_s;              // a sequence's frame time; unset: the request's start_s
  std::optional<double> previous_time_s;     // the frame before's: a scene cut keyed between the two marks this one
  std::function<Result<void>(const SceneInput& metered, PreparedPipeline& prepared, const FrameFacts& facts)> temporal;
  // Set by a sequence: its frames share one request, so the UI overlay and the grade are
  // loaded by the first frame and reused by the rest (the overlay's conversion to display
  // light is cached by object, so it is converted once too).
  std::shared_ptr<LoadedResources> resources;
};

// The EXR of an encode request: a file (CLI) or the uploaded bytes (daemon).
struct EncodeInput {
  std::filesystem::path path;
  std::string bytes;                        // the file in memory (an upload), instead of `path`
  std::string name;                         // shown in messages and the sidecar
};

struct OutputFile {
  Output id;
  std::vector<std::uint8_t> bytes;
};

struct FrameResult {
  EncodedFrame frame;
  std::vector<OutputFile> files;            // in the order asked for
  std::vector<std::string> warnings;        // everything the user should know (fallbacks, clamps)
  nlohmann::json timings_ms = nlohmann::json::object();  // render, encode, outputs
  std::string encoder;                      // "gpu" or "cpu"
  bool durable = false;                     // the request's `durable`: write_outputs fsyncs
  // The sidecar (docs/dump-format.md) without its "files": frame, target, metadata,
  // settings as resolved, the canonical request.
  nlohmann::json sidecar() const;
};

class FrameJob {
 public:
  // Resolves the display (connector, EDID, profile: cheap), so that the mode is known
  // before any work; everything that needs no render is checked here. `outputs` unset:
  // the request's `formats`, else the mode's default dump (job/outputs.hpp).
  static Result<std::unique_ptr<FrameJob>> create(FrameRequest request, JobOptions options, EncodeInput input = {},
                                                  std::optional<std::vector<Output>> outputs = std::nullopt);
  ~FrameJob();

  // Replaces the outputs (the daemon's negotiated reply format), checked against the mode.
  Result<void> set_outputs(std::vector<Output> outputs);
  // The cancellation test for the stage about to run (the daemon's JobControl).
  void set_stop(std::function<bool()> should_stop);

  bool needs_renderer() const;                 // render requests
  const DisplayTarget& target() const;         // resolved levels
  const FrameRequest& request() const;
  const std::vector<Output>& outputs() const;
  const EncodeInput& input() const;           // encode requests: the file, or its bytes

  // Render stage (render requests, on the renderer's thread): loads the grade and the UI,
  // renders, meters, encodes on the GPU when the rule allows, reads back what the CPU needs.
  Result<void> render(shading::Renderer& renderer);
  // Finish stage (anywhere): decodes an EXR input or makes the pattern, encodes on the CPU
  // when the GPU did not, and produces the outputs.
  Result<FrameResult> finish();

  struct State;

 private:
  explicit FrameJob(std::unique_ptr<State> s);
  std::unique_ptr<State> s_;
};

// Where a render is encoded. `setting` is the request's `encoder`: gpu and cpu as said;
// auto: the CPU when an output needs the display light only the CPU encoder keeps (EXR) or
// when a software rasteriser renders (there the generated program's table lookups cost more
// than the CPU encoder and its readback of the float frame: docs/performance.md), else the
// GPU pass, which spares the frame's readback. (gpu with an EXR output is refused before.)
enum class EncoderChoice { cpu, gpu };
EncoderChoice choose_encoder(std::string_view setting, shading::RendererKind kind, bool needs_display_light);

// Runs both stages (the CLI; the renderer is made when the request needs one).
Result<FrameResult> run_frame_job(FrameJob& job, shading::Renderer* renderer = nullptr);

// Writes the outputs as OUTBASE<suffix> and the sidecar as OUTBASE.json, atomically and all
// or nothing. Returns kind -> path for every file written, the sidecar included.
Result<std::map<std::string, std::string>> write_outputs(const FrameResult& result, const std::filesystem::path& outbase);

}  // namespace hdrd::job

// Video files from EncodedFrames, one frame at a time with bounded memory: hdrd's own
// R'G'B' -> Y'CbCr 4:2:0 (ycbcr.hpp), an encoder through libavcodec (HEVC Main 10 with
// libx265, AV1 10-bit with SVT-AV1 or libaom, H.264 with libx264 for SDR), and
// libavformat's MP4 or Matroska muxer, colour-tagged in the bitstream and the container.
//
// Why two passes over the compressed stream: MaxCLL/MaxFALL are known only after the last
// frame, and they belong in the bitstream (HEVC SEI, AV1 metadata OBU) of every random
// access point and in the container header (MP4 clli, Matroska MaxCLL/MaxFALL), so are
// the per-scene HDR10+ values, known when the scene ends. The encoder's packets therefore
// go to a spool file beside the output while frames arrive; finish() then muxes them into
// OUTBASE.mp4 / .mkv with every value final, inserting the metadata hdrd writes itself
// (bitstream.hpp). The spool holds compressed data only (a few MB per minute), on disk.
// The output is written under a temporary name and renamed when complete: an error,
// cancel() or destruction before finish() leaves nothing behind.
//
// Deterministic: fixed encoder settings and a fixed frame-thread count (threads, not the
// machine's core count), closed GOPs, keyframes at least every keyframe_interval_s and at
// every frame flagged as a scene start, bit-exact muxing (no tool version or time in the
// file), so the same frames give the same bytes on any machine.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"
#include "encode/video/sequence_metadata.hpp"

namespace hdrd::video {

enum class Codec { hevc, av1, h264 };
enum class Container { mp4, mkv };
std::string_view to_string(Codec c);
std::string_view to_string(Container c);
std::optional<Codec> parse_codec(std::string_view s);          // "hevc" ("h265"), "av1", "h264" ("avc")
std::optional<Container> parse_container(std::string_view s);  // "mp4", "mkv" ("matroska")
std::string_view file_extension(Container c);                  // ".mp4", ".mkv"

struct VideoSettings {
  Codec codec = Codec::hevc;
  Container container = Container::mp4;
  // Constant rate factor; nullopt: the codec's default (default_crf()). Ignored when lossless.
  std::optional<double> crf;
  // Encoder preset: x265/x264 names ("ultrafast" ... "placebo"), SVT-AV1 0..13, libaom
  // cpu-used 0..8; empty: the default (default_preset()).
  std::string preset;
  bool lossless = false;     // x265 lossless, libaom lossless (AV1), x264 qp 0 (H.264)
  Range range = Range::narrow;  // of the Y'CbCr codes
  int fps_num = 24, fps_den = 1;
  double keyframe_interval_s = 2.0;  // longest closed GOP
  int threads = 4;                   // fixed, so the bytes do not depend on the machine
  // AV1 encoder: "libsvtav1" (default) or "libaom-av1" (always for lossless AV1).
  std::string av1_encoder;
  bool dynamic_metadata = true;      // embed HDR10+ (hdr10 only)
};
double default_crf(Codec c);            // hevc 22, av1 30, h264 20
std::string default_preset(const VideoSettings& s);
Result<void> validate(const VideoSettings& s);

// Up front: the stream's size and signal. Every frame must match it.
struct StreamInfo {
  int width = 0, height = 0;
  DisplayTarget target;
  MasteringDisplay mastering;  // for hdr10/hlg: ST 2086 in bitstream and container
};

// Whether open() would take the settings for the stream (codec for the mode, bit depth,
// an even size, ...), without opening an encoder: a service answers 4xx before it starts.
Result<void> check_stream(const VideoSettings& settings, const StreamInfo& stream);

// What was written (for the sidecar): file, codec and profile as ffprobe names them,
// pixel format, the H.273 tags, the static metadata carried.
struct VideoResult {
  std::filesystem::path path;
  std::string codec;          // "hevc", "av1", "h264"
  std::string encoder;        // "libx265", "libsvtav1", "libaom-av1", "libx264"
  std::string profile;        // "Main 10", "Main", "High", "High 10", "High 4:4:4 Predictive"
  std::string pixel_format;   // "yuv420p10le", "yuv420p"
  int colour_primaries = 0, transfer_characteristics = 0, matrix_coefficients = 0;
  std::string range;          // "narrow" ("tv"), "full" ("pc")
  int frames = 0;
  std::uint64_t bytes = 0;
  std::optional<ContentLightLevel> content_light;  // carried values (whole cd/m2), HDR only
  bool hdr10plus = false;     // HDR10+ in every frame
  // What the user should know about the stream (in the sequence sidecar's and the job's
  // warnings, not in to_json): a keyframe asked for that the encoder did not make.
  std::vector<std::string> warnings;
  // Wall time in hdrd's R'G'B' -> Y'CbCr conversion, in the encoder's calls (its own
  // threads run beside them) and in the final mux; not in to_json (the bytes' description).
  double convert_ms = 0, encoder_ms = 0, mux_ms = 0;
  double convert_cpu_ms = 0;  // the R'G'B' -> Y'CbCr conversion's CPU (CpuMeter: its thread and pool tasks)
  nlohmann::json to_json() const;
};

struct FrameOptions {
  bool keyframe = false;  // force a keyframe (IDR) here, e.g. at a scene start
};

// FFmpeg and SVT-AV1 print banners and statistics to stderr by default; this makes both
// print errors only, process-wide (av_log_set_level, and SVT_LOG unless the environment
// already sets it). The CLI and the daemon call it once at start-up.
void quiet_codec_logs();

class SequenceWriter {
 public:
  // Opens the encoder and the spool; the output is OUTBASE + file_extension(container).
  static Result<std::unique_ptr<SequenceWriter>> open(const std::filesystem::path& outbase, const VideoSettings& settings,
                                                      const StreamInfo& stream);
  ~SequenceWriter();  // cancels unless finished
  SequenceWriter(const SequenceWriter&) = delete;
  SequenceWriter& operator=(const SequenceWriter&) = delete;

  // The next frame in display order (converted and encoded now; its packets spooled).
  Result<void> write(const EncodedFrame& frame, const FrameOptions& options = {});
  // Flushes the encoder and muxes the file with the sequence's metadata (content light,
  // HDR10+ per frame from `metadata`, which must have seen the same frames, finished).
  // Without metadata: content light from the frames' own EncodedFrame::content_light.
  Result<VideoResult> finish(const SequenceMetadata* metadata = nullptr);
  // Stops and removes every file this writer made.
  void cancel();

  // Sharded sequences (docs/cluster.md): instead of finish(), flush the encoder and write
  // its packets as a segment file (the spool with the encoder's parameter sets), atomically;
  // join_segments() later muxes segments in order into one file without re-encoding. Every
  // segment must come from the same settings and stream (its parameter sets are compared);
  // each starts with a keyframe (a fresh encoder), so the joined stream decodes as one.
  Result<void> finish_segment(const std::filesystem::path& segment);
  static Result<VideoResult> join_segments(const std::filesystem::path& outbase, const VideoSettings& settings,
                                           const StreamInfo& stream, std::span<const std::filesystem::path> segments,
                                           const SequenceMetadata& metadata);

  int frames_written() const;
  const std::filesystem::path& output_path() const;

  struct Impl;

 private:
  explicit SequenceWriter(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hdrd::video

// Showing a sequence of frames on a display at the mode's refresh rate (or a given frame
// rate) through KMS: the first frame is a TEST_ONLY-checked modeset that also sets the
// sequence's HDR signalling (HDR_OUTPUT_METADATA from the caller's sequence MaxCLL/MaxFALL,
// Colorspace, max bpc) exactly once; every later frame is a nonblocking atomic page flip
// (the plane's FB_ID alone) with DRM_MODE_PAGE_FLIP_EVENT. A fixed ring of 2 or 3 dumb
// buffers holds the frames, and a buffer is written only after the flip that took it off
// the screen has completed (its event was read), so memory is bounded and nothing tears.
//
// Pacing is in vblanks, counted by the flip events' sequence numbers: frame k belongs to
// the vblanks m with floor((m - m0) * fps / refresh) == k, so 24 fps on 60 Hz is 3:2
// pulldown, 30 fps holds each frame 2 vblanks (re-committing the same framebuffer at the
// vblank in between, a "repeat"), 120 fps shows every other frame ("dropped"). In
// `realtime` pacing a frame whose vblanks have all passed when it arrives is dropped (file
// playback keeps the clock); in `every_frame` pacing nothing is dropped and a late frame
// restarts the schedule (a renderer slower than the frame rate: hdrd render --present).
//
// At the end (finish(), cancel(), an error, or destruction) the last flip is waited for,
// the display is turned off with one modeset (plane, CRTC and connector off,
// HDR_OUTPUT_METADATA cleared) and every framebuffer, dumb buffer and blob is released.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "display/kms.hpp"
#include "display/kms_output.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

enum class Pacing { realtime, every_frame };
std::optional<Pacing> parse_pacing(std::string_view s);  // "realtime", "every-frame"
std::string_view to_string(Pacing p);

struct SequenceOptions {
  PresentOptions present;        // connector, scRGB policy, require_hdr_properties (test_only unused)
  double fps = 0;                // frames per second; 0 = the mode's refresh rate (one frame per vblank)
  int buffers = 2;               // 2 (double) or 3 (triple buffering: the next frame is copied while a flip is pending)
  Pacing pacing = Pacing::realtime;  // hdrd's front ends pass the present.pacing setting (its default: every-frame)
  // The sequence's static metadata (CTA-861.3): MaxCLL / MaxFALL of the whole sequence
  // and the mastering display. Unset: MaxCLL/MaxFALL "unknown" (carried as the mastering
  // peak, encode/frame.hpp carried_light_level), never one frame's values, which would
  // understate a brighter later frame; the mastering display is the first frame's.
  std::optional<ContentLightLevel> content_light;
  std::optional<MasteringDisplay> mastering;
  std::chrono::milliseconds flip_timeout{1000};  // a flip event later than this is an error (kms.flip_timeout)
  // Adds properties to the modeset (frame 0), to every frame's flip (not to repeats) and
  // to the turn-off (frame nullopt): the vkms check (tests/display/vkms) attaches a
  // writeback job to each flipped frame and detaches the writeback connector at the end.
  std::function<void(kms::AtomicRequest& request, std::optional<std::uint64_t> frame)> amend_commit;
  // Called before a buffer is written again with the frame it last held, once the flip that
  // took it off the screen has completed. On vkms the composer that feeds writeback reads
  // the planes after that flip's event, so the vkms check waits for the frame's writeback
  // fence here; a display scanning out needs nothing (the event is the release).
  std::function<void(std::uint64_t frame)> before_reuse;
};

struct SequenceStats {
  std::uint64_t frames_in = 0;       // frames given to push()
  std::uint64_t frames_shown = 0;    // frames whose flip completed
  std::uint64_t frames_dropped = 0;  // realtime pacing: frames whose vblanks had passed
  std::uint64_t frames_late = 0;     // shown after their scheduled vblank
  std::uint64_t flips = 0;           // page-flip events (frames + repeats; the modeset included)
  std::uint64_t repeats = 0;         // flips re-showing the frame on screen (fps below the refresh rate)
  double fps_target = 0;             // the pacing frame rate
  double refresh_hz = 0;             // the mode's (pixel clock / (htotal x vtotal))
  double measured_refresh_hz = 0;    // vblanks counted between the first and last flip / their time
  double measured_fps = 0;           // (frames shown - 1) / time between the first and last frame's flip
  double frame_interval_ms_mean = 0, frame_interval_ms_min = 0, frame_interval_ms_max = 0;  // between shown frames
  double elapsed_s = 0;              // first flip to the display turned off
  bool cancelled = false;
};

struct SequenceResult {
  PresentResult setup;  // device, connector, mode, planes, signalling (set once)
  SequenceStats stats;
};

class SequencePresenter {
 public:
  SequencePresenter(kms::KmsDevice& device, SequenceOptions options);
  // Owning the device (open_sequence_presenter).
  SequencePresenter(std::unique_ptr<kms::KmsDevice> device, SequenceOptions options);
  ~SequencePresenter();  // turns the display off and releases everything if finish() was not called
  SequencePresenter(const SequencePresenter&) = delete;
  SequencePresenter& operator=(const SequencePresenter&) = delete;

  // Shows the next frame at its vblank. Blocks until a buffer is free and the frame is
  // committed (at most about one frame interval plus the copy), or dropped. Every frame
  // must have the first one's size, fourcc and mode (present.frame_mismatch). After an
  // error or cancel() the display is already off and further pushes return that error
  // (present.cancelled after cancel()).
  Result<void> push(const EncodedFrame& frame);
  // Holds the last frame for its interval, turns the display off, releases the buffers.
  Result<SequenceResult> finish();
  // From any thread or a signal handler: the next push() or finish() stops cleanly.
  void cancel() { cancel_.store(true); }

  const SequenceStats& stats() const { return stats_; }
  const std::optional<PresentResult>& setup() const { return setup_; }

 private:
  struct Buffer;
  enum class BufferState { free, queued, on_screen };
  struct Flip {
    std::uint64_t serial = 0;
    int buffer = -1;
    std::optional<std::uint64_t> frame;  // empty: a repeat
    std::uint32_t due_vblank = 0;
  };

  Result<void> start(const EncodedFrame& frame);
  Result<void> show(const EncodedFrame& frame, std::uint64_t index);
  Result<void> allocate_buffers(std::uint32_t fourcc);
  Result<void> wait_flip();
  Result<void> wait_flip(std::chrono::milliseconds timeout);
  Result<void> commit_flip(int buffer, std::optional<std::uint64_t> frame, std::uint32_t due_vblank);
  Result<void> repeat_until(std::uint32_t vblank);
  std::uint32_t next_vblank() const;
  std::uint64_t frame_at(std::uint32_t vblank) const;
  std::uint32_t first_vblank_of(std::uint64_t frame) const;
  int free_buffer() const;
  Error fail(Error e);
  void shut_down();

  std::unique_ptr<kms::KmsDevice> owned_;
  kms::KmsDevice& device_;
  SequenceOptions options_;
  std::atomic<bool> cancel_{false};
  std::optional<Error> error_;
  bool finished_ = false;

  std::optional<PresentResult> setup_;
  OutputRoute route_;
  std::uint32_t fourcc_ = 0;
  int width_ = 0, height_ = 0;
  Mode mode_ = Mode::sdr;
  std::vector<Buffer> buffers_;
  std::vector<std::uint32_t> blobs_;
  std::optional<Flip> pending_;
  std::uint64_t serial_ = 0;

  // Schedule: frame k at vblank m0 + (k - k0) * refresh / fps.
  double frames_per_vblank_ = 1;
  std::uint32_t m0_ = 0;
  std::uint64_t k0_ = 0;
  // The latest flip event, and the first/last frame flips for the statistics.
  std::uint32_t last_sequence_ = 0;
  std::int64_t last_time_ns_ = 0;
  std::uint32_t first_sequence_ = 0;
  std::int64_t first_time_ns_ = 0;
  std::int64_t first_frame_ns_ = -1, last_frame_ns_ = -1;
  std::optional<std::uint64_t> last_shown_frame_;
  double interval_sum_ms_ = 0;
  SequenceStats stats_;
};

// A frame source for present_sequence: the next frame, or nullopt at the end.
using FrameSource = std::function<std::optional<Result<EncodedFrame>>()>;

// Pulls frames from `source` into a SequencePresenter until it ends, an error, or
// `presenter.cancel()`; `progress` is called after every frame (on this thread).
Result<SequenceResult> present_sequence(SequencePresenter& presenter, const FrameSource& source,
                                        const std::function<void(const SequenceStats&)>& progress = {});

}  // namespace hdrd::display

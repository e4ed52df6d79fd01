#include "display/sequence_presenter.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "display/scanout.hpp"

namespace hdrd::display {

using namespace kms;

struct SequencePresenter::Buffer {
  DumbBuffer dumb;
  std::span<std::uint8_t> map;
  std::uint32_t fb = 0;
  BufferState state = BufferState::free;
  std::optional<std::uint64_t> frame;  // the frame it holds
};

std::optional<Pacing> parse_pacing(std::string_view s) {
  if (s == "realtime") return Pacing::realtime;
  if (s == "every-frame" || s == "every_frame") return Pacing::every_frame;
  return std::nullopt;
}

std::string_view to_string(Pacing p) { return p == Pacing::realtime ? "realtime" : "every-frame"; }

namespace {

Error prefixed(Error e, const std::string& prefix) {
  e.message = prefix + ": " + e.message;
  return e;
}

// Frames prepare_for_scanout would change (scRGB to HDR10, narrow to full range); all
// others are copied into the scan-out buffer as they are, without an intermediate copy.
bool needs_conversion(const EncodedFrame& f, ScrgbPolicy policy) {
  if (f.target.mode == Mode::scrgb) return policy != ScrgbPolicy::passthrough;
  return f.target.range == Range::narrow;
}

// Vblank numbers are counted modulo 2^32, as the kernel's counter is.
std::int32_t vblanks_between(std::uint32_t from, std::uint32_t to) { return static_cast<std::int32_t>(to - from); }

}  // namespace

SequencePresenter::SequencePresenter(KmsDevice& device, SequenceOptions options)
    : device_(device), options_(std::move(options)) {}

SequencePresenter::SequencePresenter(std::unique_ptr<KmsDevice> device, SequenceOptions options)
    : owned_(std::move(device)), device_(*owned_), options_(std::move(options)) {}

SequencePresenter::~SequencePresenter() {
  if (!finished_) shut_down();
}

Error SequencePresenter::fail(Error e) {
  error_ = e;
  shut_down();
  return e;
}

int SequencePresenter::free_buffer() const {
  for (std::size_t i = 0; i < buffers_.size(); ++i)
    if (buffers_[i].state == BufferState::free) return static_cast<int>(i);
  return -1;
}

Result<void> SequencePresenter::push(const EncodedFrame& input) {
  if (error_) return *error_;
  if (finished_) return make_error("present.finished", "the sequence was already finished");
  if (stats_.cancelled || cancel_.load()) {
    if (!stats_.cancelled) shut_down();
    stats_.cancelled = true;
    return make_error("present.cancelled", "presentation was cancelled");
  }
  const std::uint64_t index = stats_.frames_in++;
  std::optional<ScanoutFrame> converted;
  if (!setup_ || needs_conversion(input, options_.present.scrgb)) {
    auto p = prepare_for_scanout(input, options_.present.scrgb);
    if (!p) return fail(prefixed(p.error(), fmt::format("frame {}", index)));
    converted = std::move(*p);
  } else if (auto c = check_frame(input); !c) {
    return fail(prefixed(c.error(), fmt::format("frame {}", index)));
  }
  const EncodedFrame& f = converted ? converted->frame : input;
  if (!setup_) {
    if (auto s = start(f); !s) return fail(s.error());
    for (auto& n : converted->notes) setup_->notes.push_back(std::move(n));
    return {};
  }
  if (f.width != width_ || f.height != height_ || f.drm_fourcc != fourcc_ || f.target.mode != mode_)
    return fail(make_error("present.frame_mismatch",
                           fmt::format("frame {} is {}x{} {} {}; the sequence started as {}x{} {} {}", index, f.width,
                                       f.height, to_string(f.target.mode), fourcc_name(f.drm_fourcc), width_, height_,
                                       to_string(mode_), fourcc_name(fourcc_)),
                           "frame"));
  if (auto s = show(f, index); !s) return fail(s.error());
  if (cancel_.load()) {
    shut_down();
    stats_.cancelled = true;
  }
  return {};
}

Result<void> SequencePresenter::allocate_buffers(std::uint32_t fourcc) {
  const int count = std::clamp(options_.buffers, 2, 3);
  const auto bpp = static_cast<std::uint32_t>(scanout_bytes_per_pixel(fourcc) * 8);
  for (int i = 0; i < count; ++i) {
    Buffer b;
    auto dumb = device_.create_dumb(route_.mode.hdisplay, route_.mode.vdisplay, bpp);
    if (!dumb) return prefixed(dumb.error(), "cannot allocate a scan-out buffer");
    b.dumb = *dumb;
    buffers_.push_back(b);  // owned from here on: shut_down() destroys it
    auto map = device_.map_dumb(*dumb);
    if (!map) return prefixed(map.error(), "cannot map a scan-out buffer");
    buffers_.back().map = *map;
    fill_black(*map, fourcc);  // once: frames only overwrite their own rectangle
    auto fb = device_.add_fb2(dumb->width, dumb->height, fourcc, dumb->handle, dumb->pitch);
    if (!fb) return prefixed(fb.error(), fmt::format("cannot create a {} framebuffer", fourcc_name(fourcc)));
    buffers_.back().fb = *fb;
  }
  return {};
}

// The first frame: a modeset with the sequence's signalling, checked with TEST_ONLY.
Result<void> SequencePresenter::start(const EncodedFrame& f) {
  auto route = plan_route(device_, f, options_.present);
  if (!route) return route.error();
  route_ = std::move(*route);
  PresentResult out;
  out.device = device_.path();
  out.connector = route_.connector.name;
  out.crtc_id = route_.crtc_id;
  out.plane_id = route_.plane_id;
  out.mode = route_.mode;
  out.fourcc = f.drm_fourcc;
  out.signal = f.target.mode;
  if (auto note = fit_note(f, route_.mode)) out.notes.push_back(*note);
  width_ = f.width;
  height_ = f.height;
  fourcc_ = f.drm_fourcc;
  mode_ = f.target.mode;
  setup_ = out;  // from here on shut_down() has something to release

  if (auto b = allocate_buffers(f.drm_fourcc); !b) return b.error();
  copy_frame(f, buffers_[0].dumb, buffers_[0].map);
  buffers_[0].frame = 0;
  out.fb_id = buffers_[0].fb;

  AtomicRequest req;
  auto mode_blob = device_.create_mode_blob(route_.mode);
  if (!mode_blob) return prefixed(mode_blob.error(), "MODE_ID blob");
  blobs_.push_back(*mode_blob);
  add_modeset(route_, *mode_blob, req);
  add_flip(route_, buffers_[0].fb, req);
  // The signalling describes the sequence, not this frame: its metadata only, no pixels.
  EncodedFrame described;
  described.target = f.target;
  described.drm_fourcc = f.drm_fourcc;
  described.mastering = options_.mastering.value_or(f.mastering);
  const ContentLightLevel light = options_.content_light.value_or(ContentLightLevel{});
  if (auto s = add_signalling(device_, described, light, route_, options_.present, req, out, blobs_); !s)
    return s.error();
  if (options_.amend_commit) options_.amend_commit(req, 0);
  if (auto t = device_.atomic_commit(req, kAtomicTestOnly | kAtomicAllowModeset); !t)
    return prefixed(t.error(), fmt::format("{} rejected the configuration in a TEST_ONLY commit", out.device));
  if (auto c = device_.atomic_commit_with_event(req, kAtomicAllowModeset | kAtomicNonblock, ++serial_); !c)
    return prefixed(c.error(), fmt::format("atomic commit on {} failed", out.device));
  out.committed = true;
  setup_ = out;
  buffers_[0].state = BufferState::queued;
  pending_ = Flip{serial_, 0, 0, 0};

  const double refresh = route_.mode.refresh_hz();
  stats_.refresh_hz = refresh;
  stats_.fps_target = options_.fps > 0 ? options_.fps : refresh;
  frames_per_vblank_ = options_.fps > 0 && refresh > 0 ? options_.fps / refresh : 1.0;
  // Sets m0_ from the modeset's vblank; a modeset may train a link for a while.
  return wait_flip(std::max(options_.flip_timeout, std::chrono::milliseconds(5000)));
}

Result<void> SequencePresenter::show(const EncodedFrame& f, std::uint64_t k) {
  int b = free_buffer();
  while (b < 0) {  // double buffering: the buffer off screen is still queued
    if (auto w = wait_flip(); !w) return w;
    b = free_buffer();
  }
  if (options_.before_reuse && buffers_[b].frame) options_.before_reuse(*buffers_[b].frame);
  copy_frame(f, buffers_[b].dumb, buffers_[b].map);
  buffers_[b].frame = k;
  if (pending_)  // one commit in flight per CRTC: the next vblank is known once it completed
    if (auto w = wait_flip(); !w) return w;

  std::uint32_t due = first_vblank_of(k);
  if (k < frame_at(next_vblank())) {  // every vblank of frame k has passed
    if (options_.pacing == Pacing::realtime) {
      ++stats_.frames_dropped;
      return {};
    }
    m0_ = next_vblank();  // every_frame: the schedule restarts at this frame
    k0_ = k;
  } else if (auto r = repeat_until(due); !r) {
    return r;
  }
  if (cancel_.load()) return {};
  return commit_flip(b, k, due);
}

Result<void> SequencePresenter::commit_flip(int buffer, std::optional<std::uint64_t> frame, std::uint32_t due) {
  AtomicRequest req;
  add_flip(route_, buffers_[buffer].fb, req);
  if (frame && options_.amend_commit) options_.amend_commit(req, frame);
  if (auto c = device_.atomic_commit_with_event(req, kAtomicNonblock, ++serial_); !c)
    return prefixed(c.error(), fmt::format("page flip on {} failed", device_.path()));
  if (frame) buffers_[buffer].state = BufferState::queued;
  pending_ = Flip{serial_, buffer, frame, due};
  return {};
}

// Holds the frame on screen until `vblank` by re-committing its framebuffer at each
// vblank in between: every commit's event keeps the loop locked to the display.
Result<void> SequencePresenter::repeat_until(std::uint32_t vblank) {
  while (vblanks_between(next_vblank(), vblank) > 0 && !cancel_.load()) {
    int on_screen = -1;
    for (std::size_t i = 0; i < buffers_.size(); ++i)
      if (buffers_[i].state == BufferState::on_screen) on_screen = static_cast<int>(i);
    if (on_screen < 0) return make_error("present.state", "no frame on screen to hold");
    if (auto c = commit_flip(on_screen, std::nullopt, vblank); !c) return c;
    if (auto w = wait_flip(); !w) return w;
  }
  return {};
}

// The vblank a commit made now takes effect at (no flip pending): the one after the last
// event, plus any that passed since.
std::uint32_t SequencePresenter::next_vblank() const {
  const double period_ns = stats_.refresh_hz > 0 ? 1e9 / stats_.refresh_hz : 1e9 / 60;
  const std::int64_t since = device_.now_ns() - last_time_ns_;
  const auto missed = since > 0 ? static_cast<std::uint32_t>(double(since) / period_ns) : 0u;
  return last_sequence_ + 1 + missed;
}

// The frame vblank m shows: k0 + floor((m - m0) * fps / refresh). The epsilon keeps exact
// ratios (30 on 60 Hz) from flickering between two frames on rounding.
std::uint64_t SequencePresenter::frame_at(std::uint32_t m) const {
  const std::int32_t d = vblanks_between(m0_, m);
  if (d <= 0) return k0_;
  return k0_ + static_cast<std::uint64_t>(std::floor(d * frames_per_vblank_ + 1e-9));
}

// The first vblank m with frame_at(m) >= k.
std::uint32_t SequencePresenter::first_vblank_of(std::uint64_t k) const {
  if (k <= k0_) return m0_;
  return m0_ + static_cast<std::uint32_t>(std::ceil(double(k - k0_) / frames_per_vblank_ - 1e-9));
}

Result<void> SequencePresenter::wait_flip() { return wait_flip(options_.flip_timeout); }

Result<void> SequencePresenter::wait_flip(std::chrono::milliseconds timeout) {
  if (!pending_) return {};
  const std::int64_t deadline = device_.now_ns() + std::int64_t(timeout.count()) * 1'000'000;
  for (;;) {
    const std::int64_t left_ms = (deadline - device_.now_ns()) / 1'000'000;
    if (left_ms <= 0)
      return make_error("kms.flip_timeout", fmt::format("no page-flip event from {} within {} ms", device_.path(),
                                                        timeout.count()));
    auto events = device_.read_flip_events(std::chrono::milliseconds(std::min<std::int64_t>(left_ms, 100)));
    if (!events) return events.error();
    for (const FlipEvent& e : *events) {
      if (e.user_data != pending_->serial) continue;  // not ours (a previous presenter's)
      const Flip flip = *pending_;
      pending_.reset();
      ++stats_.flips;
      last_sequence_ = e.sequence;
      last_time_ns_ = e.timestamp_ns;
      if (stats_.flips == 1) {
        first_sequence_ = e.sequence;
        first_time_ns_ = e.timestamp_ns;
        m0_ = e.sequence;  // frame 0 is on screen: the schedule starts here
      }
      if (!flip.frame) {
        ++stats_.repeats;
        return {};
      }
      for (std::size_t i = 0; i < buffers_.size(); ++i)
        if (buffers_[i].state == BufferState::on_screen && static_cast<int>(i) != flip.buffer)
          buffers_[i].state = BufferState::free;  // off the screen now: may be written
      buffers_[flip.buffer].state = BufferState::on_screen;
      ++stats_.frames_shown;
      if (stats_.flips > 1 && vblanks_between(flip.due_vblank, e.sequence) > 0) ++stats_.frames_late;
      if (last_frame_ns_ >= 0) {
        const double ms = double(e.timestamp_ns - last_frame_ns_) / 1e6;
        interval_sum_ms_ += ms;
        stats_.frame_interval_ms_min = stats_.frames_shown == 2 ? ms : std::min(stats_.frame_interval_ms_min, ms);
        stats_.frame_interval_ms_max = std::max(stats_.frame_interval_ms_max, ms);
        stats_.frame_interval_ms_mean = interval_sum_ms_ / double(stats_.frames_shown - 1);
      }
      if (first_frame_ns_ < 0) first_frame_ns_ = e.timestamp_ns;
      last_frame_ns_ = e.timestamp_ns;
      last_shown_frame_ = flip.frame;
      if (vblanks_between(first_sequence_, last_sequence_) > 0 && last_time_ns_ > first_time_ns_)
        stats_.measured_refresh_hz =
            vblanks_between(first_sequence_, last_sequence_) / (double(last_time_ns_ - first_time_ns_) / 1e9);
      if (last_frame_ns_ > first_frame_ns_)
        stats_.measured_fps = double(stats_.frames_shown - 1) / (double(last_frame_ns_ - first_frame_ns_) / 1e9);
      return {};
    }
  }
}

Result<SequenceResult> SequencePresenter::finish() {
  if (error_) return *error_;
  if (finished_) return make_error("present.finished", "the sequence was already finished");
  if (!setup_ && !stats_.cancelled && !cancel_.load())
    return make_error("present.no_frames", "the sequence has no frames to present");
  if (!stats_.cancelled && !cancel_.load()) {
    Result<void> held = wait_flip();
    if (held && last_shown_frame_) held = repeat_until(first_vblank_of(*last_shown_frame_ + 1));
    if (!held) return fail(held.error());
  }
  stats_.cancelled = stats_.cancelled || cancel_.load();
  shut_down();
  finished_ = true;
  return SequenceResult{setup_.value_or(PresentResult{}), stats_};
}

// Waits for the flip in flight, turns the display off and releases every buffer and blob.
void SequencePresenter::shut_down() {
  if (pending_ && !wait_flip())
    pending_.reset();  // a hung flip: the blocking modeset below waits for the kernel's own timeout
  if (setup_ && setup_->committed) {
    AtomicRequest req;
    add_disable(route_, req);
    if (options_.amend_commit) options_.amend_commit(req, std::nullopt);
    if (auto off = device_.atomic_commit(req, kAtomicAllowModeset); !off)
      setup_->notes.push_back("turning the display off failed: " + off.error().message);
    setup_->committed = false;
    if (first_time_ns_) stats_.elapsed_s = double(device_.now_ns() - first_time_ns_) / 1e9;
  }
  for (auto& b : buffers_) {
    if (b.fb) device_.remove_fb(b.fb);
    device_.destroy_dumb(b.dumb);
  }
  buffers_.clear();
  for (auto id : blobs_) device_.destroy_blob(id);
  blobs_.clear();
}

Result<SequenceResult> present_sequence(SequencePresenter& presenter, const FrameSource& source,
                                        const std::function<void(const SequenceStats&)>& progress) {
  for (;;) {
    auto next = source();
    if (!next) break;
    if (!*next) {
      presenter.cancel();  // the display goes off at once, not after holding the last frame
      (void)presenter.finish();
      return next->error();
    }
    if (auto r = presenter.push(**next); !r) {
      if (r.error().code == "present.cancelled") break;
      return r.error();
    }
    if (progress) progress(presenter.stats());
  }
  return presenter.finish();
}

}  // namespace hdrd::display

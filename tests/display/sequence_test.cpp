// SequencePresenter against the fake device's simulated vblanks: frames in order, one per
// vblank at the mode's rate; the HDR signalling set once; no buffer written before the
// flip that took it off the screen; pacing at frame rates below and above the refresh
// rate (the cadences computed by hand: 30 on 60 Hz holds 2 vblanks, 24 on 60 Hz is 3:2
// pulldown, 120 on 60 Hz shows every other frame); slow producers; cancellation; errors
// mid-sequence leave the device dark with nothing allocated.
#include <gtest/gtest.h>

#include <cstring>
#include <set>

#include "display/sequence_presenter.hpp"
#include "tests/display/fake_kms.hpp"

namespace hdrd::display {
namespace {

using namespace hdrd::display::testing;
constexpr auto H = FakeKmsDevice::kHdmi;
constexpr auto kCrtc = FakeKmsDevice::kCrtc;
constexpr auto kPrimary = FakeKmsDevice::kPrimary;

// A 64x32 HDR10 frame (the fake has a 64x32 60 Hz mode) whose first pixel carries `index`.
EncodedFrame frame(std::uint32_t index, int w = 64, int h = 32) {
  EncodedFrame f;
  f.target = default_target(Mode::hdr10);
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = static_cast<std::size_t>(w) * 4;
  f.data.assign(f.stride_bytes * h, 0x11);
  std::memcpy(f.data.data(), &index, 4);
  f.mastering = MasteringDisplay{color::kDisplayP3, 1000.0, 0.005};
  f.content_light = {100.0 + index, 10.0 + index};  // per frame: must not reach the display
  return f;
}

EncodedFrame sdr_frame(std::uint32_t index) {
  EncodedFrame f = frame(index);
  f.target = default_target(Mode::sdr);
  f.drm_fourcc = kDrmFormatXrgb8888;
  return f;
}

// The frames the CRTC showed, in vblank order: (first word, vblank number). Repeats and
// the final turn-off are left out.
std::vector<std::pair<std::uint32_t, std::uint32_t>> shown(const FakeKmsDevice& dev) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
  std::uint32_t fb = 0;
  for (const auto& s : dev.scanouts) {
    if (s.fb != 0 && (out.empty() || s.fb != fb || s.first_word != out.back().first))
      out.emplace_back(s.first_word, s.sequence);
    fb = s.fb;
  }
  return out;
}

void expect_clean(const FakeKmsDevice& dev) {
  EXPECT_EQ(dev.state(kCrtc, "ACTIVE"), 0u);
  EXPECT_EQ(dev.state(kPrimary, "FB_ID"), 0u);
  EXPECT_EQ(dev.state(H, "CRTC_ID"), 0u);
  EXPECT_EQ(dev.state(H, "HDR_OUTPUT_METADATA"), 0u);
  EXPECT_EQ(dev.visible_fb(), 0u);
  EXPECT_FALSE(dev.flip_pending());
  EXPECT_TRUE(dev.framebuffers.empty());
  EXPECT_EQ(dev.live_dumbs, 0);
  EXPECT_TRUE(dev.blobs.empty());
  EXPECT_TRUE(dev.violations.empty()) << dev.violations.front();
}

Result<SequenceResult> run(FakeKmsDevice& dev, int frames, SequenceOptions o = {},
                           const std::function<void(int)>& before_frame = {}) {
  SequencePresenter p(dev, o);
  for (int i = 0; i < frames; ++i) {
    if (before_frame) before_frame(i);
    if (auto r = p.push(frame(static_cast<std::uint32_t>(i))); !r) return r.error();
  }
  return p.finish();
}

TEST(FakeKmsFlips, EventAtTheNextVblankAndEbusyWhilePending) {
  FakeKmsDevice dev;
  AtomicRequest req;
  req.add(kCrtc, *dev.properties(kCrtc, kObjectCrtc), "ACTIVE", 1);
  req.add(kPrimary, *dev.properties(kPrimary, kObjectPlane), "CRTC_ID", kCrtc);
  ASSERT_TRUE(dev.atomic_commit_with_event(req, kAtomicNonblock, 7).ok());
  auto busy = dev.atomic_commit_with_event(req, kAtomicNonblock, 8);
  ASSERT_FALSE(busy.ok());
  EXPECT_EQ(busy.error().code, "kms.busy");
  auto ev = dev.read_flip_events(std::chrono::milliseconds(100));
  ASSERT_TRUE(ev.ok());
  ASSERT_EQ(ev->size(), 1u);
  EXPECT_EQ((*ev)[0].user_data, 7u);
  EXPECT_EQ((*ev)[0].sequence, 1u);  // the clock starts at 5 ms: vblank 1 at 16.67 ms
  EXPECT_EQ((*ev)[0].timestamp_ns, dev.period_ns);
  EXPECT_TRUE(dev.read_flip_events(std::chrono::milliseconds(10))->empty());  // nothing pending: a timeout
}

TEST(FakeKmsFlips, DetectsAWriteToTheBufferOnScreen) {
  // The negative control for every "no violations" below.
  FakeKmsDevice dev;
  auto d = *dev.create_dumb(64, 32, 32);
  auto fb = *dev.add_fb2(64, 32, kDrmFormatXrgb8888, d.handle, d.pitch);
  AtomicRequest req;
  req.add(kCrtc, *dev.properties(kCrtc, kObjectCrtc), "ACTIVE", 1);
  req.add(kPrimary, *dev.properties(kPrimary, kObjectPlane), "CRTC_ID", kCrtc);
  req.add(kPrimary, *dev.properties(kPrimary, kObjectPlane), "FB_ID", fb);
  ASSERT_TRUE(dev.atomic_commit_with_event(req, kAtomicNonblock, 1).ok());
  (*dev.map_dumb(d))[0] = 0x42;  // written while queued
  dev.advance(20'000'000);
  ASSERT_EQ(dev.violations.size(), 1u);
  EXPECT_EQ(dev.violations[0], fmt::format("fb {} was written between its commit and its flip", fb));
  dev.remove_fb(fb);  // while on screen
  EXPECT_EQ(dev.violations.size(), 2u);
}

TEST(SequencePresenter, FramesInOrderOnePerVblankAtTheModeRate) {
  FakeKmsDevice dev;
  auto r = run(dev, 12);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto s = shown(dev);
  ASSERT_EQ(s.size(), 12u);
  for (std::uint32_t i = 0; i < s.size(); ++i) {
    EXPECT_EQ(s[i].first, i);
    EXPECT_EQ(s[i].second, s[0].second + i) << "frame " << i << " not on consecutive vblanks";
  }
  const SequenceStats& st = r->stats;
  EXPECT_EQ(st.frames_in, 12u);
  EXPECT_EQ(st.frames_shown, 12u);
  EXPECT_EQ(st.flips, 12u);
  EXPECT_EQ(st.repeats, 0u);
  EXPECT_EQ(st.frames_dropped, 0u);
  EXPECT_EQ(st.frames_late, 0u);
  EXPECT_DOUBLE_EQ(st.refresh_hz, 60.0);  // 148.5 MHz / (2200 x 1125)
  EXPECT_DOUBLE_EQ(st.fps_target, 60.0);
  EXPECT_NEAR(st.measured_refresh_hz, 60.0, 1e-3);
  EXPECT_NEAR(st.measured_fps, 60.0, 1e-3);
  EXPECT_NEAR(st.frame_interval_ms_mean, 1000.0 / 60, 1e-3);
  EXPECT_NEAR(st.frame_interval_ms_max, 1000.0 / 60, 1e-3);
  EXPECT_FALSE(st.cancelled);
  EXPECT_EQ(r->setup.mode.hdisplay, 64);
  EXPECT_EQ(dev.peak_dumbs, 2);  // double buffering: memory does not grow with the frames
  expect_clean(dev);
}

TEST(SequencePresenter, SignallingIsSetOnceFromTheSequenceLightLevel) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.content_light = ContentLightLevel{1500.2, 300.0};  // the whole sequence's, given by the caller
  SequencePresenter p(dev, o);
  ASSERT_TRUE(p.push(frame(0)).ok());
  const auto& blob = dev.blobs.at(static_cast<std::uint32_t>(dev.state(H, "HDR_OUTPUT_METADATA")));
  EXPECT_EQ(blob[26] | (blob[27] << 8), 1000);  // MaxCLL 1500.2: never above the mastering maximum
  EXPECT_EQ(blob[28] | (blob[29] << 8), 300);
  EXPECT_EQ(blob[22] | (blob[23] << 8), 1000);  // mastering peak, from the first frame
  for (std::uint32_t i = 1; i < 8; ++i) ASSERT_TRUE(p.push(frame(i)).ok());
  auto r = p.finish();
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(dev.blobs_created, 1);
  int with_meta = 0, with_colorspace = 0, with_bpc = 0, modesets = 0;
  for (const auto& c : dev.commits) {
    if (c.flags & kAtomicTestOnly) continue;
    for (const auto& item : c.items) {
      with_meta += item.name == "HDR_OUTPUT_METADATA" && item.value != 0;
      with_colorspace += item.name == "Colorspace";
      with_bpc += item.name == "max bpc";
      modesets += item.name == "MODE_ID";
    }
  }
  EXPECT_EQ(with_meta, 1);
  EXPECT_EQ(with_colorspace, 1);
  EXPECT_EQ(with_bpc, 1);
  EXPECT_EQ(modesets, 2);  // the first frame and the turn-off
  ASSERT_TRUE(r->setup.hdr_metadata);
  EXPECT_EQ(r->setup.hdr_metadata->max_cll, 1000);
  EXPECT_EQ(r->setup.colorspace, "BT2020_RGB");
  // Every commit after the first frame is a flip: the plane's FB_ID alone, nonblocking.
  std::size_t first_flip = 0;
  while (!(dev.commits[first_flip].flags & kPageFlipEvent)) ++first_flip;
  for (std::size_t i = first_flip + 1; i + 1 < dev.commits.size(); ++i) {
    EXPECT_EQ(dev.commits[i].flags, kAtomicNonblock | kPageFlipEvent);
    ASSERT_EQ(dev.commits[i].items.size(), 1u);
    EXPECT_EQ(dev.commits[i].items[0].name, "FB_ID");
  }
  expect_clean(dev);
}

TEST(SequencePresenter, UnknownSequenceLightLevelIsCarriedAsTheMasteringPeak) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  ASSERT_TRUE(p.push(frame(5)).ok());  // this frame says MaxCLL 105: not the sequence's
  const auto& blob = dev.blobs.at(static_cast<std::uint32_t>(dev.state(H, "HDR_OUTPUT_METADATA")));
  EXPECT_EQ(blob[26] | (blob[27] << 8), 1000);
  EXPECT_EQ(blob[28] | (blob[29] << 8), 1000);
}

TEST(SequencePresenter, SdrSequenceClearsHdrMetadataOnce) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  for (std::uint32_t i = 0; i < 4; ++i) ASSERT_TRUE(p.push(sdr_frame(i)).ok());
  auto r = p.finish();
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->setup.colorspace, "Default");
  EXPECT_FALSE(r->setup.hdr_metadata);
  EXPECT_EQ(dev.blobs_created, 0);
  EXPECT_EQ(shown(dev).size(), 4u);
  expect_clean(dev);
}

class Buffering : public ::testing::TestWithParam<int> {};

TEST_P(Buffering, NoBufferIsWrittenBeforeItsFlipCompleted) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.buffers = GetParam();
  // A producer with jitter: some frames come at once, some after up to 1.5 vblanks.
  auto r = run(dev, 40, o, [&](int i) { dev.advance((i * 7 % 5) * 5'000'000); });
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(dev.violations.empty()) << dev.violations.front();
  EXPECT_EQ(dev.peak_dumbs, GetParam());
  std::set<std::uint32_t> fbs;
  for (const auto& s : dev.scanouts)
    if (s.fb) fbs.insert(s.fb);
  EXPECT_EQ(fbs.size(), static_cast<std::size_t>(GetParam()));
  const auto s = shown(dev);
  for (std::size_t i = 1; i < s.size(); ++i) EXPECT_GT(s[i].first, s[i - 1].first);
  EXPECT_EQ(r->stats.frames_shown + r->stats.frames_dropped, 40u);
  expect_clean(dev);
}

INSTANTIATE_TEST_SUITE_P(SequencePresenter, Buffering, ::testing::Values(2, 3),
                         [](const auto& info) { return info.param == 2 ? "double" : "triple"; });

struct Cadence {
  const char* name;
  double fps;
  int frames;
  std::vector<std::uint32_t> shown_frames;  // by hand
  std::vector<std::uint32_t> vblank_gaps;   // between them, by hand
  std::uint64_t dropped, repeats;
};

void PrintTo(const Cadence& c, std::ostream* os) { *os << c.name; }  // readable in ctest, not bytes

class PacingCadence : public ::testing::TestWithParam<Cadence> {};

TEST_P(PacingCadence, FramesLandOnTheVblanksOfTheirRate) {
  const Cadence& c = GetParam();
  FakeKmsDevice dev;
  SequenceOptions o;
  o.fps = c.fps;
  auto r = run(dev, c.frames, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto s = shown(dev);
  ASSERT_EQ(s.size(), c.shown_frames.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_EQ(s[i].first, c.shown_frames[i]);
    if (i) {
      EXPECT_EQ(s[i].second - s[i - 1].second, c.vblank_gaps[i - 1]) << "before frame " << s[i].first;
    }
  }
  EXPECT_EQ(r->stats.frames_dropped, c.dropped);
  EXPECT_EQ(r->stats.repeats, c.repeats);
  EXPECT_EQ(r->stats.frames_late, 0u);
  EXPECT_DOUBLE_EQ(r->stats.fps_target, c.fps);
  // The last frame is held for its own interval too: the display goes off at the vblank
  // the next frame would have had.
  expect_clean(dev);
}

INSTANTIATE_TEST_SUITE_P(
    SequencePresenter, PacingCadence,
    ::testing::Values(
        // 30 on 60 Hz: 2 vblanks each; a repeat between frames and one holding the last.
        Cadence{"fps30", 30, 6, {0, 1, 2, 3, 4, 5}, {2, 2, 2, 2, 2}, 0, 6},
        // 24 on 60 Hz: 3:2 pulldown (2.5 vblanks a frame); the last (5, from vblank 13)
        // holds until 15, where frame 6 would start.
        Cadence{"fps24", 24, 6, {0, 1, 2, 3, 4, 5}, {3, 2, 3, 2, 3}, 0, 2 + 1 + 2 + 1 + 2 + 1},
        // 120 on 60 Hz: vblank m shows frame 2m; the odd frames have no vblank.
        Cadence{"fps120", 120, 10, {0, 2, 4, 6, 8}, {1, 1, 1, 1}, 5, 0},
        // 60 on 60 Hz given explicitly: the same as the default.
        Cadence{"fps60", 60, 4, {0, 1, 2, 3}, {1, 1, 1}, 0, 0}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(SequencePresenter, Fps30StatisticsMatchTheCadence) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.fps = 30;
  auto r = run(dev, 10, o);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->stats.measured_fps, 30.0, 1e-3);
  EXPECT_NEAR(r->stats.frame_interval_ms_mean, 1000.0 / 30, 1e-3);
  EXPECT_NEAR(r->stats.frame_interval_ms_min, 1000.0 / 30, 1e-3);
  EXPECT_NEAR(r->stats.measured_refresh_hz, 60.0, 1e-3);
  // 10 frames at 30 fps: 20 vblanks from the first flip to the turn-off.
  EXPECT_NEAR(r->stats.elapsed_s, 20.0 / 60, 1.0 / 60 + 1e-6);
}

// fps 20 (3 vblanks a frame); the producer stalls 190 ms before frame 4. Frame 3 is queued
// for vblank 9 (relative to frame 0's); when frame 4 arrives the next vblank is 20, which
// belongs to frame floor(20 / 3) = 6.
TEST(SequencePresenter, StallRealtimeDropsFramesWhoseVblanksPassed) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.fps = 20;
  auto r = run(dev, 10, o, [&](int i) { if (i == 4) dev.advance(190'000'000); });
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto s = shown(dev);
  std::vector<std::uint32_t> frames, at;
  for (auto [f, seq] : s) frames.push_back(f), at.push_back(seq - s[0].second);
  EXPECT_EQ(frames, (std::vector<std::uint32_t>{0, 1, 2, 3, 6, 7, 8, 9}));
  EXPECT_EQ(at, (std::vector<std::uint32_t>{0, 3, 6, 9, 20, 21, 24, 27}));
  EXPECT_EQ(r->stats.frames_dropped, 2u);  // 4 (vblanks 12-14) and 5 (15-17)
  EXPECT_EQ(r->stats.frames_late, 1u);     // 6, due at 18, shown at 20
  expect_clean(dev);
}

TEST(SequencePresenter, StallEveryFrameShowsAllAndRestartsTheSchedule) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.fps = 20;
  o.pacing = Pacing::every_frame;
  auto r = run(dev, 10, o, [&](int i) { if (i == 4) dev.advance(190'000'000); });
  ASSERT_TRUE(r.ok()) << r.error().message;
  std::vector<std::uint32_t> at;
  const auto s = shown(dev);
  for (auto [f, seq] : s) at.push_back(seq - s[0].second);
  EXPECT_EQ(at, (std::vector<std::uint32_t>{0, 3, 6, 9, 20, 23, 26, 29, 32, 35}));
  EXPECT_EQ(r->stats.frames_dropped, 0u);
  EXPECT_EQ(r->stats.frames_late, 1u);
  expect_clean(dev);
}

TEST(SequencePresenter, CancelStopsAtTheNextFrameAndTurnsTheDisplayOff) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  std::uint32_t next = 0;
  auto r = present_sequence(p, [&]() -> std::optional<Result<EncodedFrame>> {
    if (next == 5) p.cancel();  // e.g. SIGINT; the loop would go on for ever otherwise
    return Result<EncodedFrame>(frame(next++));
  });
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->stats.cancelled);
  EXPECT_EQ(r->stats.frames_shown, 5u);
  EXPECT_EQ(shown(dev).size(), 5u);
  expect_clean(dev);
  EXPECT_EQ(p.push(frame(9)).error().code, "present.finished");

  FakeKmsDevice dev2;  // cancelled from outside the loop: pushes say so, finish reports it
  SequencePresenter q(dev2, {});
  ASSERT_TRUE(q.push(frame(0)).ok());
  ASSERT_TRUE(q.push(frame(1)).ok());
  q.cancel();
  EXPECT_EQ(q.push(frame(2)).error().code, "present.cancelled");
  expect_clean(dev2);  // off at once, not at finish()
  EXPECT_EQ(q.push(frame(3)).error().code, "present.cancelled");
  auto done = q.finish();
  ASSERT_TRUE(done.ok());
  EXPECT_TRUE(done->stats.cancelled);
  EXPECT_EQ(done->stats.frames_shown, 2u);
}

TEST(SequencePresenter, FailedFlipMidSequenceLeavesTheDeviceClean) {
  FakeKmsDevice dev;
  dev.fail_flip_number = 4;  // the modeset is flip 1: frame 3's flip fails
  SequencePresenter p(dev, {});
  Result<void> r;
  std::uint32_t i = 0;
  for (; i < 8 && r; ++i) r = p.push(frame(i));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(i, 4u);
  EXPECT_EQ(r.error().code, "kms.atomic");
  EXPECT_EQ(r.error().message, "page flip on /dev/dri/fake0 failed: Invalid argument");
  expect_clean(dev);
  EXPECT_EQ(p.push(frame(9)).error().message, r.error().message);
  EXPECT_EQ(p.finish().error().code, "kms.atomic");
}

TEST(SequencePresenter, AFrameOfAnotherShapeIsAnErrorNamingIt) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  ASSERT_TRUE(p.push(frame(0)).ok());
  ASSERT_TRUE(p.push(frame(1)).ok());
  auto r = p.push(frame(2, 32, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "present.frame_mismatch");
  EXPECT_EQ(r.error().message, "frame 2 is 32x32 hdr10 XB30; the sequence started as 64x32 hdr10 XB30");
  expect_clean(dev);
  EncodedFrame broken = frame(0);
  broken.data.resize(7);
  FakeKmsDevice dev2;
  SequencePresenter p2(dev2, {});
  ASSERT_TRUE(p2.push(frame(0)).ok());
  EXPECT_EQ(p2.push(broken).error().code, "scanout.size");
  expect_clean(dev2);
}

TEST(SequencePresenter, AHungDisplayEngineIsATimeoutNotAHang) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  ASSERT_TRUE(p.push(frame(0)).ok());
  dev.vblanks_stalled = true;
  Result<void> r;
  for (std::uint32_t i = 1; i < 5 && r; ++i) r = p.push(frame(i));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "kms.flip_timeout");
  EXPECT_EQ(r.error().message, "no page-flip event from /dev/dri/fake0 within 1000 ms");
  EXPECT_EQ(dev.live_dumbs, 0);
  EXPECT_TRUE(dev.framebuffers.empty());
}

TEST(SequencePresenter, RejectedConfigurationCommitsNothing) {
  FakeKmsDevice dev;
  dev.reject_test_only_errno = EINVAL;
  SequencePresenter p(dev, {});
  auto r = p.push(frame(0));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "/dev/dri/fake0 rejected the configuration in a TEST_ONLY commit: Invalid argument");
  EXPECT_EQ(dev.commits.size(), 1u);
  EXPECT_EQ(dev.live_dumbs, 0);
  EXPECT_TRUE(dev.blobs.empty());
}

TEST(SequencePresenter, SourceErrorStopsAndTurnsOff) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  std::uint32_t next = 0;
  auto r = present_sequence(p, [&]() -> std::optional<Result<EncodedFrame>> {
    if (next == 3) return Result<EncodedFrame>(make_error("dump.raw", "frame 3: cannot read x.raw"));
    return Result<EncodedFrame>(frame(next++));
  });
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "dump.raw");
  expect_clean(dev);
}

TEST(SequencePresenter, NoFramesAndFinishTwiceAreErrors) {
  FakeKmsDevice dev;
  SequencePresenter p(dev, {});
  EXPECT_EQ(p.finish().error().code, "present.no_frames");
  SequencePresenter q(dev, {});
  ASSERT_TRUE(q.push(frame(0)).ok());
  ASSERT_TRUE(q.finish().ok());
  EXPECT_EQ(q.finish().error().code, "present.finished");
  EXPECT_EQ(q.push(frame(1)).error().code, "present.finished");
  expect_clean(dev);
}

TEST(SequencePresenter, DestructionWithoutFinishTurnsTheDisplayOff) {
  FakeKmsDevice dev;
  {
    SequencePresenter p(dev, {});
    ASSERT_TRUE(p.push(frame(0)).ok());
    ASSERT_TRUE(p.push(frame(1)).ok());
  }
  expect_clean(dev);
}

TEST(SequencePresenter, AmendCommitReachesTheModesetAndEveryFrameFlipOnly) {
  FakeKmsDevice dev;
  SequenceOptions o;
  o.fps = 30;  // repeats in between: not amended
  std::vector<std::int64_t> amended;  // -1: the turn-off
  const Properties dpms = *dev.properties(H, kObjectConnector);
  o.amend_commit = [&](AtomicRequest& r, std::optional<std::uint64_t> k) {
    amended.push_back(k ? static_cast<std::int64_t>(*k) : -1);
    r.add(H, dpms, "DPMS", 0);
  };
  auto r = run(dev, 4, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(amended, (std::vector<std::int64_t>{0, 1, 2, 3, -1}));  // built once for TEST_ONLY and the modeset
  int with_dpms = 0;
  for (const auto& c : dev.commits)
    for (const auto& item : c.items) with_dpms += item.name == "DPMS";
  EXPECT_EQ(with_dpms, 6);  // TEST_ONLY, modeset, 3 flips, turn-off
  expect_clean(dev);
}

TEST(SequencePresenter, BeforeReuseNamesTheFrameABufferHeld) {
  for (int buffers : {2, 3}) {
    FakeKmsDevice dev;
    SequenceOptions o;
    o.buffers = buffers;
    std::vector<std::uint64_t> reused;
    o.before_reuse = [&](std::uint64_t k) {
      reused.push_back(k);
      EXPECT_TRUE(dev.scanouts.size() > 0);
    };
    ASSERT_TRUE(run(dev, 6, o).ok());
    // Each buffer is written again with frame k + buffers after frame k left it.
    std::vector<std::uint64_t> want;
    for (std::uint64_t k = 0; k + buffers < 6; ++k) want.push_back(k);
    EXPECT_EQ(reused, want) << buffers << " buffers";
  }
}

TEST(PacingNames, ParsesTheCliSpelling) {
  EXPECT_EQ(parse_pacing("realtime"), Pacing::realtime);
  EXPECT_EQ(parse_pacing("every-frame"), Pacing::every_frame);
  EXPECT_FALSE(parse_pacing("fast"));
}

}  // namespace
}  // namespace hdrd::display

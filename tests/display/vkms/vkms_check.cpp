// Runs inside a VM with the vkms module loaded (see run_vkms_test.sh): enumerates the
// vkms connectors through hdrd's libdrm code, shows an SDR XRGB8888 frame with
// KmsOutput (TEST_ONLY, then the real commit), captures the CRTC through vkms's writeback
// connector, and compares the captured pixels with the frame. Then asks for HDR10
// (XBGR2101010) to record what vkms refuses. Then shows a sequence with SequencePresenter
// (a modeset, then nonblocking page flips with events, double buffering) with one
// writeback job on every flipped frame, and checks that capture k holds frame k.
// Prints "VKMS_CHECK PASS" or "VKMS_CHECK FAIL".
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

#include <fmt/format.h>

#include "display/displays.hpp"
#include "display/drm_device.hpp"
#include "display/kms_output.hpp"
#include "display/sequence_presenter.hpp"

using namespace hdrd;
using namespace hdrd::display;

namespace {

int failures = 0;
void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  failures += !ok;
}

EncodedFrame test_frame(int w, int h, int shift = 0) {
  EncodedFrame f;
  f.target = default_target(Mode::sdr);
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXrgb8888;
  f.stride_bytes = static_cast<std::size_t>(w) * 4;
  f.data.resize(f.stride_bytes * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = f.data.data() + y * f.stride_bytes + 4 * x;
      p[0] = static_cast<std::uint8_t>(x * 255 / (w - 1) + shift * 37);  // B ramp, moving with the frame
      p[1] = static_cast<std::uint8_t>(y * 255 / (h - 1));  // G ramp
      p[2] = static_cast<std::uint8_t>(((x + 16 * shift) / 64 + y / 64) % 2 ? 0xf0 : 0x10);  // R checkerboard
      p[3] = 0xff;
    }
  return f;
}

// Commits the writeback connector onto the CRTC and waits for its out-fence. With
// `detach` set, the display connector is taken off the CRTC in the same commit.
bool capture(DrmDevice& dev, std::uint32_t crtc, std::uint32_t wb_conn, std::uint32_t fb, std::uint32_t detach) {
  auto props = dev.properties(wb_conn, kms::kObjectConnector);
  if (!props) return false;
  std::int32_t fence = -1;
  kms::AtomicRequest req;
  if (detach) {
    auto dprops = dev.properties(detach, kms::kObjectConnector);
    if (!dprops) return false;
    req.add(detach, *dprops, "CRTC_ID", 0);
  }
  req.add(wb_conn, *props, "CRTC_ID", crtc);
  req.add(wb_conn, *props, "WRITEBACK_FB_ID", fb);
  req.add(wb_conn, *props, "WRITEBACK_OUT_FENCE_PTR", reinterpret_cast<std::uintptr_t>(&fence));
  // Routing the writeback connector to the CRTC is a modeset.
  if (auto r = dev.atomic_commit(req, kms::kAtomicAllowModeset); !r) {
    std::printf("writeback commit: %s\n", r.error().message.c_str());
    return false;
  }
  if (fence >= 0) {
    pollfd p{fence, POLLIN, 0};
    poll(&p, 1, 5000);
    close(fence);
  }
  return true;
}

int mismatches(const EncodedFrame& f, const std::uint8_t* captured, std::uint32_t pitch) {
  int n = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      n += std::memcmp(f.data.data() + y * f.stride_bytes + 4 * x, captured + y * pitch + 4 * x, 3) != 0;
  return n;
}

// A sequence through SequencePresenter with a writeback job on the modeset and on every
// flip (each into its own buffer), the display connector detached as vkms 6.1 wants.
void check_sequence(DrmDevice& dev, std::uint32_t display_conn, std::uint32_t wb) {
  constexpr int kFrames = 8, kW = 1024, kH = 768;
  auto wb_props = dev.properties(wb, kms::kObjectConnector);
  auto display_props = dev.properties(display_conn, kms::kObjectConnector);
  if (!wb || !wb_props || !display_props) return check(false, "sequence: the writeback connector's properties");
  struct Capture {
    kms::DumbBuffer dumb;
    std::span<std::uint8_t> map;
    std::uint32_t fb = 0;
    std::int32_t fence = -1;
    std::int64_t frame = -1;
  };
  std::vector<Capture> cap(kFrames);
  for (auto& c : cap) {
    auto d = dev.create_dumb(kW, kH, 32);
    auto m = d ? dev.map_dumb(*d) : Result<std::span<std::uint8_t>>(make_error("x", "no dumb"));
    auto fb = d ? dev.add_fb2(kW, kH, kDrmFormatXrgb8888, d->handle, d->pitch) : Result<std::uint32_t>(make_error("x", "x"));
    if (!m || !fb) return check(false, "sequence: writeback buffers");
    c = {*d, *m, *fb, -1, -1};
  }
  std::uint32_t crtc = 0;
  int next = 0;
  SequenceOptions o;
  o.present.require_hdr_properties = false;
  o.pacing = Pacing::every_frame;  // TCG is slow: show every frame rather than keep the clock
  o.amend_commit = [&](kms::AtomicRequest& r, std::optional<std::uint64_t> frame) {
    if (!frame) return r.add(wb, *wb_props, "CRTC_ID", 0);  // the turn-off: detach writeback too
    if (*frame == 0) {
      for (const auto& item : r.items())
        if (item.name == "MODE_ID") crtc = item.object;
      r.add(display_conn, *display_props, "CRTC_ID", 0);  // overrides add_modeset's (libdrm keeps the last)
      r.add(wb, *wb_props, "CRTC_ID", crtc);
    }
    if (next >= kFrames) return;
    // vkms composes a state's writeback in a worker after its vblank; a commit that
    // replaces the state before that worker ran ends the job unwritten (seen under TCG:
    // one capture in eight all black). A display engine latches every frame it flips to,
    // so the check lets vkms finish the previous capture before it commits the next frame.
    if (next > 0 && cap[next - 1].fence >= 0) {
      pollfd p{cap[next - 1].fence, POLLIN, 0};
      poll(&p, 1, 5000);
    }
    cap[next].frame = static_cast<std::int64_t>(*frame);
    r.add(wb, *wb_props, "WRITEBACK_FB_ID", cap[next].fb);
    r.add(wb, *wb_props, "WRITEBACK_OUT_FENCE_PTR", reinterpret_cast<std::uintptr_t>(&cap[next].fence));
    ++next;
  };
  // vkms composes the writeback from the planes after the flip's event: a buffer is
  // written again only once the capture of the frame it held is done.
  o.before_reuse = [&](std::uint64_t frame) {
    for (auto& c : cap)
      if (c.frame == static_cast<std::int64_t>(frame) && c.fence >= 0) {
        pollfd p{c.fence, POLLIN, 0};
        poll(&p, 1, 5000);
      }
  };
  SequencePresenter presenter(dev, o);
  std::vector<EncodedFrame> frames;
  for (int k = 0; k < kFrames; ++k) frames.push_back(test_frame(kW, kH, k));
  for (int k = 0; k < kFrames; ++k)
    if (auto r = presenter.push(frames[k]); !r) return check(false, fmt::format("sequence frame {}: {}", k, r.error().message));
  // For the same reason the last capture is waited for before finish() holds the last frame
  // and turns the display off: vkms would otherwise end that writeback job unwritten when
  // the CRTC goes off before its composer ran (seen on 6.1 under TCG: capture 7 all black).
  if (next > 0 && cap[next - 1].fence >= 0) {
    pollfd p{cap[next - 1].fence, POLLIN, 0};
    poll(&p, 1, 5000);
  }
  auto done = presenter.finish();
  check(done.ok(), "sequence: " + (done.ok() ? std::string("finished, display off") : done.error().message));
  if (!done) return;
  const SequenceStats& s = done->stats;
  std::printf("  sequence: %llu frames shown, %llu flips, %llu late, %.2f fps measured, refresh %.3f Hz (mode %.3f), "
              "interval %.2f..%.2f ms\n", static_cast<unsigned long long>(s.frames_shown),
              static_cast<unsigned long long>(s.flips), static_cast<unsigned long long>(s.frames_late), s.measured_fps,
              s.measured_refresh_hz, s.refresh_hz, s.frame_interval_ms_min, s.frame_interval_ms_max);
  check(s.frames_shown == kFrames && s.frames_dropped == 0, "sequence: every frame flipped");
  check(next == kFrames, fmt::format("sequence: one writeback job per flipped frame ({})", next));
  for (int i = 0; i < next; ++i) {
    if (cap[i].fence >= 0) {
      pollfd p{cap[i].fence, POLLIN, 0};
      poll(&p, 1, 5000);
      close(cap[i].fence);
      cap[i].fence = -2;  // waited for and closed
    }
    const EncodedFrame& f = frames[static_cast<std::size_t>(cap[i].frame)];
    const int bad = mismatches(f, cap[i].map.data(), cap[i].dumb.pitch);
    int best = -1;  // which frame the capture is, if not the expected one
    for (int k = 0; k < kFrames && bad; ++k)
      if (mismatches(frames[k], cap[i].map.data(), cap[i].dumb.pitch) == 0) best = k;
    check(cap[i].fence == -2 && bad == 0,
          fmt::format("writeback {} holds frame {} ({} pixels differ{})", i, cap[i].frame, bad,
                      best >= 0 ? fmt::format("; it is frame {}", best) : ""));
  }
  for (auto& c : cap) {
    dev.remove_fb(c.fb);
    dev.destroy_dumb(c.dumb);
  }
}

}  // namespace

int main() {
  const auto paths = drm_card_paths();
  check(!paths.empty(), fmt::format("drmGetDevices2 finds the vkms device ({} device(s))", paths.size()));
  if (paths.empty()) return std::puts("VKMS_CHECK FAIL"), 1;
  auto dev = DrmDevice::open(paths.front(), /*writeback=*/true);
  check(dev.ok(), "open " + paths.front() + (dev.ok() ? "" : ": " + dev.error().message));
  if (!dev) return std::puts("VKMS_CHECK FAIL"), 1;
  check((*dev)->driver() == "vkms", "driver is vkms (" + (*dev)->driver() + ")");
  check((*dev)->atomic(), "atomic modesetting");

  auto conns = describe_connectors(**dev);
  check(conns.ok() && !conns->empty(), "describe_connectors");
  for (const auto& c : *conns)
    std::printf("  %s %s, %zu modes, HDR_OUTPUT_METADATA %s, Colorspace %s\n", c.connector.name.c_str(),
                std::string(kms::to_string(c.connector.status)).c_str(), c.connector.modes.size(),
                c.has_hdr_output_metadata ? "yes" : "no", c.colorspaces.empty() ? "absent" : "present");

  const EncodedFrame frame = test_frame(1024, 768);
  KmsOutput out(**dev);
  auto shown = out.show(frame);
  check(shown.ok(), "SDR XR24 frame: TEST_ONLY then commit" + (shown.ok() ? "" : ": " + shown.error().message));
  if (!shown) return std::puts("VKMS_CHECK FAIL"), 1;
  std::printf("  shown on %s %dx%d crtc %u plane %u fb %u\n", shown->connector.c_str(), shown->mode.hdisplay,
              shown->mode.vdisplay, shown->crtc_id, shown->plane_id, shown->fb_id);

  // Writeback: a buffer of the mode's size on the writeback connector.
  auto res = (*dev)->resources();
  std::uint32_t wb = 0;
  for (auto id : res->connectors)
    if (auto c = (*dev)->connector(id); c && c->type == kms::kConnectorTypeWriteback) wb = id;
  check(wb != 0, "vkms has a writeback connector");
  auto dumb = (*dev)->create_dumb(shown->mode.hdisplay, shown->mode.vdisplay, 32);
  auto map = dumb ? (*dev)->map_dumb(*dumb) : Result<std::span<std::uint8_t>>(make_error("x", "no dumb"));
  auto fb = dumb ? (*dev)->add_fb2(dumb->width, dumb->height, kDrmFormatXrgb8888, dumb->handle, dumb->pitch)
                 : Result<std::uint32_t>(make_error("x", "no dumb"));
  check(map.ok() && fb.ok(), "writeback buffer");
  std::uint32_t display_conn = 0;
  for (auto id : res->connectors)
    if (auto c = (*dev)->connector(id); c && c->name == shown->connector) display_conn = id;
  bool captured = wb && map && fb && capture(**dev, shown->crtc_id, wb, *fb, 0);
  if (!captured && wb && map && fb) {
    std::puts("  retrying the capture with the display connector detached");
    captured = capture(**dev, shown->crtc_id, wb, *fb, display_conn);
  }
  if (captured) {
    int mismatches = 0;
    for (int y = 0; y < frame.height; ++y)
      for (int x = 0; x < frame.width; ++x) {
        const std::uint8_t* a = frame.data.data() + y * frame.stride_bytes + 4 * x;
        const std::uint8_t* b = map->data() + y * dumb->pitch + 4 * x;
        mismatches += std::memcmp(a, b, 3) != 0;  // B, G, R; X is undefined
      }
    check(mismatches == 0, fmt::format("writeback matches the frame ({} of {} pixels differ)", mismatches,
                                       frame.width * frame.height));
  } else {
    check(false, "writeback capture");
  }

  // HDR10 on vkms: no XBGR2101010 plane format and no HDR properties in 6.1.
  EncodedFrame hdr = frame;
  hdr.target = default_target(Mode::hdr10);
  hdr.drm_fourcc = kDrmFormatXbgr2101010;
  auto refused = out.show(hdr);
  std::printf("  HDR10 XB30: %s\n", refused ? "accepted" : refused.error().message.c_str());
  check(!refused.ok(), "HDR10 is refused with a clear error on vkms");

  check_sequence(**dev, display_conn, wb);

  std::puts(failures ? "VKMS_CHECK FAIL" : "VKMS_CHECK PASS");
  return failures ? 1 : 0;
}

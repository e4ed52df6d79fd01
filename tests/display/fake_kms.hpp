// An in-memory KMS device for tests: one CRTC, an HDMI connector with HDR properties
// (optional), a disconnected DP connector, a primary and an overlay plane. It records
// every atomic commit, checks that each property id belongs to the object it is set on,
// and applies only non-TEST_ONLY commits to its state. Knobs make it reject commits.
//
// Page flips are modelled on a simulated CLOCK_MONOTONIC: vblank n happens at
// n x the committed mode's frame period (htotal x vtotal / pixel clock). A commit with a
// page-flip event takes effect at the first vblank after it and then queues its event
// (sequence n, that vblank's time); a nonblocking commit while one is pending fails with
// EBUSY, a blocking one waits for it, as the kernel does. `scanouts` records what the CRTC
// showed after every vblank that changed or re-committed the plane, with a hash of the
// buffer's memory; `violations` records every write to a buffer between the commit that
// queued it and the flip that took it off the screen, and every framebuffer or dumb buffer
// destroyed while queued or on screen (the tearing and use-after-free bugs of a flip loop).
#pragma once

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "display/hdr_metadata.hpp"
#include "display/kms.hpp"
#include "encode/frame.hpp"

namespace hdrd::display::testing {

using namespace hdrd::display::kms;

inline ModeInfo make_mode(std::uint16_t w, std::uint16_t h, std::uint32_t clock_khz, std::uint16_t htotal,
                          std::uint16_t vtotal, bool preferred) {
  ModeInfo m;
  m.clock_khz = clock_khz;
  m.hdisplay = w;
  m.vdisplay = h;
  m.htotal = htotal;
  m.vtotal = vtotal;
  m.vrefresh = 60;
  m.type = preferred ? kModeTypePreferred : 0;
  m.name = fmt::format("{}x{}", w, h);
  return m;
}

class FakeKmsDevice : public KmsDevice {
 public:
  static constexpr std::uint32_t kHdmi = 31, kDp = 32, kCrtc = 41, kPrimary = 51, kOverlay = 52;

  explicit FakeKmsDevice(bool hdr_properties = true, bool hdmi_connected = true) {
    Connector hdmi;
    hdmi.id = kHdmi;
    hdmi.type = 11;  // DRM_MODE_CONNECTOR_HDMIA
    hdmi.type_id = 1;
    hdmi.name = "HDMI-A-1";
    hdmi.status = hdmi_connected ? ConnectionStatus::connected : ConnectionStatus::disconnected;
    hdmi.possible_crtcs = 1;
    if (hdmi_connected) {
      hdmi.modes = {make_mode(1920, 1080, 148500, 2200, 1125, false), make_mode(3840, 2160, 594000, 4400, 2250, true),
                    make_mode(64, 32, 148500, 2200, 1125, false)};
    }
    connectors_ = {hdmi};
    Connector dp;
    dp.id = kDp;
    dp.type = 10;  // DisplayPort
    dp.type_id = 1;
    dp.name = "DP-1";
    dp.status = ConnectionStatus::disconnected;
    dp.possible_crtcs = 1;
    connectors_.push_back(dp);

    add_prop(kHdmi, "CRTC_ID", PropertyKind::object);
    add_prop(kHdmi, "EDID", PropertyKind::blob);
    add_prop(kHdmi, "DPMS", PropertyKind::enumeration, {{"On", 0}, {"Off", 3}});
    if (hdr_properties) {
      add_prop(kHdmi, "HDR_OUTPUT_METADATA", PropertyKind::blob);
      add_prop(kHdmi, "Colorspace", PropertyKind::enumeration,
               {{"Default", DRM_MODE_COLORIMETRY_DEFAULT}, {"BT709_YCC", DRM_MODE_COLORIMETRY_BT709_YCC},
                {"BT2020_RGB", DRM_MODE_COLORIMETRY_BT2020_RGB}, {"BT2020_YCC", DRM_MODE_COLORIMETRY_BT2020_YCC}});
      add_prop(kHdmi, "max bpc", PropertyKind::range, {}, 8, 12, 8);
    }
    add_prop(kDp, "CRTC_ID", PropertyKind::object);
    add_prop(kCrtc, "MODE_ID", PropertyKind::blob);
    add_prop(kCrtc, "ACTIVE", PropertyKind::range, {}, 0, 1);
    for (std::uint32_t plane : {kPrimary, kOverlay}) {
      add_prop(plane, "type", PropertyKind::enumeration, {{"Overlay", 0}, {"Primary", 1}, {"Cursor", 2}},
               0, 0, plane == kPrimary ? 1 : 0);
      for (const char* n : {"FB_ID", "CRTC_ID"}) add_prop(plane, n, PropertyKind::object);
      for (const char* n : {"SRC_X", "SRC_Y", "SRC_W", "SRC_H", "CRTC_X", "CRTC_Y", "CRTC_W", "CRTC_H"})
        add_prop(plane, n, PropertyKind::range, {}, 0, 0xffffffff);
    }
    planes_ = {{kPrimary, 1, {kDrmFormatXrgb8888, kDrmFormatXbgr2101010, kDrmFormatAbgr16161616f}},
               {kOverlay, 1, {kDrmFormatXrgb8888}}};
  }

  // Knobs.
  int reject_test_only_errno = 0;
  int reject_commit_errno = 0;
  int fail_flip_number = 0;     // the Nth (1-based) commit with a page-flip event fails with EINVAL
  bool vblanks_stalled = false;  // pending flips never complete (a hung display engine)
  std::vector<std::uint8_t> edid;  // served as the HDMI connector's EDID blob when set

  struct Commit {
    std::vector<AtomicRequest::Item> items;
    std::uint32_t flags = 0;
  };
  std::vector<Commit> commits;
  std::map<std::uint32_t, std::vector<std::uint8_t>> blobs;
  std::map<std::uint32_t, std::vector<std::uint8_t>> dumb_memory;  // by handle
  struct Fb {
    std::uint32_t width, height, fourcc, handle, pitch;
  };
  std::map<std::uint32_t, Fb> framebuffers;
  int live_dumbs = 0;
  int flip_commits = 0;   // commits with a page-flip event, TEST_ONLY excluded
  int blobs_created = 0;  // create_blob calls (HDR_OUTPUT_METADATA; MODE_ID blobs not counted)
  int peak_dumbs = 0;     // the most dumb buffers alive at once

  // Simulated CLOCK_MONOTONIC; vblank n at n x period_ns.
  std::int64_t clock_ns = 5'000'000;
  std::int64_t period_ns = 16'666'667;
  struct Scanout {
    std::uint32_t fb = 0;          // 0: plane off
    std::uint32_t sequence = 0;    // vblank number
    std::int64_t time_ns = 0;
    std::uint64_t content_hash = 0;
    std::uint32_t first_word = 0;  // the buffer's first 4 bytes (tests put the frame number there)
    std::uint64_t user_data = 0;
  };
  std::vector<Scanout> scanouts;
  std::vector<std::string> violations;
  bool flip_pending() const { return pending_.has_value(); }
  std::uint32_t visible_fb() const { return visible_fb_; }
  // Time passes (e.g. a slow producer); flips whose vblank passed complete.
  void advance(std::int64_t ns) {
    clock_ns += ns;
    settle();
  }

  // Plugs a display into DP-1 too, with the HDR properties (HDMI keeps whatever it has).
  void connect_dp_with_hdr() {
    connectors_[1].status = ConnectionStatus::connected;
    connectors_[1].modes = {make_mode(2560, 1440, 241500, 2720, 1481, true)};
    add_prop(kDp, "HDR_OUTPUT_METADATA", PropertyKind::blob);
    add_prop(kDp, "Colorspace", PropertyKind::enumeration,
             {{"Default", DRM_MODE_COLORIMETRY_DEFAULT}, {"BT2020_RGB", DRM_MODE_COLORIMETRY_BT2020_RGB}});
  }

  void set_plane_formats(std::uint32_t plane, std::vector<std::uint32_t> formats) {
    for (auto& p : planes_)
      if (p.id == plane) p.formats = std::move(formats);
  }

  std::uint64_t state(std::uint32_t object, const std::string& name) const {
    for (const auto& p : props_.at(object))
      if (p.name == name) return p.value;
    throw std::runtime_error("no property " + name);
  }
  std::uint32_t prop_id(std::uint32_t object, const std::string& name) const {
    for (const auto& p : props_.at(object))
      if (p.name == name) return p.id;
    return 0;
  }

  std::string path() const override { return "/dev/dri/fake0"; }
  std::string driver() const override { return "fake"; }
  Result<Resources> resources() override {
    Resources r;
    for (const auto& c : connectors_) r.connectors.push_back(c.id);
    r.crtcs = {kCrtc};
    for (const auto& p : planes_) r.planes.push_back(p.id);
    return r;
  }
  Result<Connector> connector(std::uint32_t id) override {
    for (const auto& c : connectors_)
      if (c.id == id) return c;
    return make_error("kms.ioctl", "no such connector");
  }
  Result<Plane> plane(std::uint32_t id) override {
    for (const auto& p : planes_)
      if (p.id == id) return p;
    return make_error("kms.ioctl", "no such plane");
  }
  Result<Properties> properties(std::uint32_t object, std::uint32_t) override {
    auto it = props_.find(object);
    if (it == props_.end()) return make_error("kms.ioctl", "no such object");
    Properties p = it->second;
    if (object == kHdmi && !edid.empty()) {
      for (auto& prop : p)
        if (prop.name == "EDID") prop.value = store_blob(edid);
    }
    return p;
  }
  Result<std::vector<std::uint8_t>> blob(std::uint32_t id) override {
    auto it = blobs.find(id);
    if (it == blobs.end()) return make_error("kms.ioctl", "no such blob");
    return it->second;
  }
  Result<std::uint32_t> create_blob(std::span<const std::uint8_t> bytes) override {
    ++blobs_created;
    return store_blob({bytes.begin(), bytes.end()});
  }
  Result<std::uint32_t> create_mode_blob(const ModeInfo& m) override {
    std::vector<std::uint8_t> b(68, 0);
    std::memcpy(b.data(), &m.clock_khz, 4);
    std::memcpy(b.data() + 4, &m.hdisplay, 2);
    std::memcpy(b.data() + 14, &m.vdisplay, 2);
    if (m.clock_khz && m.htotal && m.vtotal)
      mode_periods_[next_blob_] = std::int64_t(m.htotal) * m.vtotal * 1'000'000'000 / (std::int64_t(m.clock_khz) * 1000);
    return store_blob(b);
  }
  void destroy_blob(std::uint32_t id) override { blobs.erase(id); }
  Result<DumbBuffer> create_dumb(std::uint32_t w, std::uint32_t h, std::uint32_t bpp) override {
    DumbBuffer d;
    d.handle = next_handle_++;
    d.width = w;
    d.height = h;
    d.bpp = bpp;
    d.pitch = (w * bpp / 8 + 63) / 64 * 64;  // drivers align the pitch
    d.size = std::uint64_t(d.pitch) * h;
    dumb_memory[d.handle].assign(d.size, 0xcd);  // garbage, as fresh memory may be
    peak_dumbs = std::max(peak_dumbs, ++live_dumbs);
    return d;
  }
  Result<std::span<std::uint8_t>> map_dumb(const DumbBuffer& d) override {
    auto& mem = dumb_memory.at(d.handle);
    return std::span<std::uint8_t>(mem);
  }
  void destroy_dumb(const DumbBuffer& d) override {
    for (const auto& [id, fb] : framebuffers)
      if (fb.handle == d.handle && in_use(id)) violations.push_back(fmt::format("dumb buffer {} destroyed while fb {} is in use", d.handle, id));
    dumb_memory.erase(d.handle);
    --live_dumbs;
  }
  Result<std::uint32_t> add_fb2(std::uint32_t w, std::uint32_t h, std::uint32_t fourcc, std::uint32_t handle,
                                std::uint32_t pitch) override {
    if (!dumb_memory.count(handle)) return make_error("kms.ioctl", "add_fb2: bad handle");
    const std::uint32_t id = next_fb_++;
    framebuffers[id] = {w, h, fourcc, handle, pitch};
    return id;
  }
  void remove_fb(std::uint32_t id) override {
    if (in_use(id)) violations.push_back(fmt::format("fb {} removed while queued or on screen", id));
    framebuffers.erase(id);
  }

  Result<void> atomic_commit(const AtomicRequest& req, std::uint32_t flags) override {
    return commit(req, flags, std::nullopt);
  }
  Result<void> atomic_commit_with_event(const AtomicRequest& req, std::uint32_t flags,
                                        std::uint64_t user_data) override {
    return commit(req, flags | kPageFlipEvent, user_data);
  }
  Result<std::vector<FlipEvent>> read_flip_events(std::chrono::milliseconds timeout) override {
    settle();
    const std::int64_t timeout_ns = std::int64_t(timeout.count()) * 1'000'000;
    if (events_.empty() && pending_ && !vblanks_stalled && vblank_time(pending_->sequence) <= clock_ns + timeout_ns) {
      clock_ns = std::max(clock_ns, vblank_time(pending_->sequence));
      settle();
    } else if (events_.empty()) {
      clock_ns += timeout_ns;
    }
    std::vector<FlipEvent> out(events_.begin(), events_.end());
    events_.clear();
    return out;
  }
  std::int64_t now_ns() const override { return clock_ns; }

 private:
  struct Pending {
    std::uint32_t sequence = 0;  // the vblank it takes effect at
    std::uint64_t user_data = 0;
    std::uint32_t fb = 0;
    std::uint64_t hash_at_commit = 0;
  };

  Result<void> commit(const AtomicRequest& req, std::uint32_t flags, std::optional<std::uint64_t> user_data) {
    if (req.failed()) return make_error("kms.request", req.error());
    commits.push_back({req.items(), flags});
    for (const auto& item : req.items()) {
      const auto it = props_.find(item.object);
      const bool owned = it != props_.end() && std::any_of(it->second.begin(), it->second.end(), [&](const Property& p) {
                           return p.id == item.property;
                         });
      if (!owned) return make_error("kms.atomic", fmt::format("{} ({})", std::strerror(EINVAL), item.name));
    }
    const bool test = flags & kAtomicTestOnly;
    if (test && reject_test_only_errno) return make_error("kms.atomic", std::strerror(reject_test_only_errno));
    if (!test && reject_commit_errno) return make_error("kms.atomic", std::strerror(reject_commit_errno));
    if (test) return {};
    settle();
    if (pending_ && (flags & kAtomicNonblock)) return make_error("kms.busy", std::strerror(EBUSY));
    if (pending_) {  // a blocking commit waits for the previous one
      if (vblanks_stalled) return make_error("kms.atomic", "flip_done timed out");
      clock_ns = std::max(clock_ns, vblank_time(pending_->sequence));
      settle();
    }
    if (user_data && ++flip_commits == fail_flip_number) return make_error("kms.atomic", std::strerror(EINVAL));
    for (const auto& item : req.items())
      for (auto& p : props_[item.object])
        if (p.id == item.property) p.value = item.value;
    if (const auto it = mode_periods_.find(static_cast<std::uint32_t>(state(kCrtc, "MODE_ID"))); it != mode_periods_.end())
      period_ns = it->second;
    const std::uint32_t fb = static_cast<std::uint32_t>(state(kPrimary, "FB_ID"));
    const bool active = state(kCrtc, "ACTIVE") && state(kPrimary, "CRTC_ID");
    if (user_data && active) {
      pending_ = Pending{current_vblank() + 1, *user_data, fb, hash_fb(fb)};
    } else {  // no event: shown at once (the tests' blocking single-frame commits, turning off)
      leave_screen(active ? fb : 0);
      visible_fb_ = active ? fb : 0;
      visible_hash_ = hash_fb(visible_fb_);
      scanouts.push_back({visible_fb_, current_vblank(), clock_ns, visible_hash_, first_word(visible_fb_), 0});
    }
    return {};
  }

  std::uint32_t current_vblank() const { return static_cast<std::uint32_t>(clock_ns / period_ns); }
  std::int64_t vblank_time(std::uint32_t n) const { return std::int64_t(n) * period_ns; }
  bool in_use(std::uint32_t fb) const { return fb && (fb == visible_fb_ || (pending_ && pending_->fb == fb)); }
  std::uint64_t hash_fb(std::uint32_t fb) const {
    const auto it = framebuffers.find(fb);
    if (it == framebuffers.end()) return 0;
    std::uint64_t h = 1469598103934665603ull;  // FNV-1a
    for (std::uint8_t b : dumb_memory.at(it->second.handle)) h = (h ^ b) * 1099511628211ull;
    return h;
  }
  std::uint32_t first_word(std::uint32_t fb) const {
    const auto it = framebuffers.find(fb);
    if (it == framebuffers.end()) return 0;
    std::uint32_t v = 0;
    std::memcpy(&v, dumb_memory.at(it->second.handle).data(), 4);
    return v;
  }
  // The buffer on screen is replaced: it must not have been written while it was shown.
  void leave_screen(std::uint32_t next_fb) {
    if (visible_fb_ && visible_fb_ != next_fb && framebuffers.count(visible_fb_) && hash_fb(visible_fb_) != visible_hash_)
      violations.push_back(fmt::format("fb {} was written while on screen", visible_fb_));
  }
  // Completes a pending flip whose vblank has passed.
  void settle() {
    if (!pending_ || vblanks_stalled || vblank_time(pending_->sequence) > clock_ns) return;
    const Pending p = *pending_;
    pending_.reset();
    if (hash_fb(p.fb) != p.hash_at_commit)
      violations.push_back(fmt::format("fb {} was written between its commit and its flip", p.fb));
    leave_screen(p.fb);
    if (p.fb != visible_fb_ || hash_fb(p.fb) != visible_hash_) visible_hash_ = hash_fb(p.fb);
    visible_fb_ = p.fb;
    const std::int64_t t = vblank_time(p.sequence);
    scanouts.push_back({p.fb, p.sequence, t, visible_hash_, first_word(p.fb), p.user_data});
    events_.push_back({p.user_data, kCrtc, p.sequence, t});
  }

  void add_prop(std::uint32_t object, std::string name, PropertyKind kind,
                std::vector<std::pair<std::string, std::uint64_t>> enums = {}, std::uint64_t min = 0,
                std::uint64_t max = 0, std::uint64_t value = 0) {
    Property p;
    p.id = 1000 + 37 * next_prop_++;  // not guessable from the name or order
    p.name = std::move(name);
    p.kind = kind;
    p.enums = std::move(enums);
    p.min = min;
    p.max = max;
    p.value = value;
    props_[object].push_back(std::move(p));
  }
  std::uint32_t store_blob(std::vector<std::uint8_t> bytes) {
    const std::uint32_t id = next_blob_++;
    blobs[id] = std::move(bytes);
    return id;
  }

  std::vector<Connector> connectors_;
  std::vector<Plane> planes_;
  std::map<std::uint32_t, Properties> props_;
  std::uint32_t next_prop_ = 0, next_blob_ = 500, next_handle_ = 7, next_fb_ = 90;
  std::map<std::uint32_t, std::int64_t> mode_periods_;  // MODE_ID blob -> frame period
  std::optional<Pending> pending_;
  std::deque<FlipEvent> events_;
  std::uint32_t visible_fb_ = 0;
  std::uint64_t visible_hash_ = 0;
};

}  // namespace hdrd::display::testing

// An in-memory KMS device for tests: one CRTC, an HDMI connector with HDR properties
// (optional), a disconnected DP connector, a primary and an overlay plane. It records
// every atomic commit, checks that each property id belongs to the object it is set on,
// and applies only non-TEST_ONLY commits to its state. Knobs make it reject commits.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
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
    return store_blob({bytes.begin(), bytes.end()});
  }
  Result<std::uint32_t> create_mode_blob(const ModeInfo& m) override {
    std::vector<std::uint8_t> b(68, 0);
    std::memcpy(b.data(), &m.clock_khz, 4);
    std::memcpy(b.data() + 4, &m.hdisplay, 2);
    std::memcpy(b.data() + 14, &m.vdisplay, 2);
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
    ++live_dumbs;
    return d;
  }
  Result<std::span<std::uint8_t>> map_dumb(const DumbBuffer& d) override {
    auto& mem = dumb_memory.at(d.handle);
    return std::span<std::uint8_t>(mem);
  }
  void destroy_dumb(const DumbBuffer& d) override {
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
  void remove_fb(std::uint32_t id) override { framebuffers.erase(id); }

  Result<void> atomic_commit(const AtomicRequest& req, std::uint32_t flags) override {
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
    for (const auto& item : req.items())
      for (auto& p : props_[item.object])
        if (p.id == item.property) p.value = item.value;
    return {};
  }

 private:
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
};

}  // namespace hdrd::display::testing

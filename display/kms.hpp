// A narrow KMS device interface: what hdrd needs from a DRM device to enumerate
// connectors and to scan out one frame with an atomic commit. drm_device.cpp implements
// it with libdrm; tests use a fake (tests/display/fake_kms.hpp). Property ids are always
// looked up by name, as wlroots does, never hard-coded.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "encode/result.hpp"

namespace hdrd::display::kms {

// drm_mode.h values, repeated so this header needs no libdrm (drm_device.cpp asserts them).
inline constexpr std::uint32_t kObjectConnector = 0xc0c0c0c0;
inline constexpr std::uint32_t kObjectCrtc = 0xcccccccc;
inline constexpr std::uint32_t kObjectPlane = 0xeeeeeeee;
inline constexpr std::uint32_t kPageFlipEvent = 0x01;
inline constexpr std::uint32_t kAtomicTestOnly = 0x0100;
inline constexpr std::uint32_t kAtomicNonblock = 0x0200;
inline constexpr std::uint32_t kAtomicAllowModeset = 0x0400;
inline constexpr std::uint32_t kModeTypePreferred = 1u << 3;
inline constexpr std::uint32_t kConnectorTypeWriteback = 18;

// drmModeModeInfo, field for field (68 bytes in the kernel's struct drm_mode_modeinfo).
struct ModeInfo {
  std::uint32_t clock_khz = 0;
  std::uint16_t hdisplay = 0, hsync_start = 0, hsync_end = 0, htotal = 0, hskew = 0;
  std::uint16_t vdisplay = 0, vsync_start = 0, vsync_end = 0, vtotal = 0, vscan = 0;
  std::uint32_t vrefresh = 0, flags = 0, type = 0;
  std::string name;
  bool preferred() const { return type & kModeTypePreferred; }
  double refresh_hz() const;
};

enum class PropertyKind { range, signed_range, enumeration, bitmask, blob, object };

struct Property {
  std::uint32_t id = 0;
  std::string name;
  PropertyKind kind = PropertyKind::range;
  std::uint64_t value = 0;                               // current value (blob id for blobs)
  std::vector<std::pair<std::string, std::uint64_t>> enums;  // enumeration / bitmask entries
  std::uint64_t min = 0, max = 0;                        // ranges
  bool immutable = false;
  std::optional<std::uint64_t> enum_value(std::string_view entry) const;
};

using Properties = std::vector<Property>;
const Property* find_property(const Properties& props, std::string_view name);

enum class ConnectionStatus { connected, disconnected, unknown };
std::string_view to_string(ConnectionStatus s);

struct Connector {
  std::uint32_t id = 0;
  std::uint32_t type = 0;        // DRM_MODE_CONNECTOR_*
  std::uint32_t type_id = 0;
  std::string name;              // "HDMI-A-1", "DP-2", as the kernel names it in sysfs
  ConnectionStatus status = ConnectionStatus::unknown;
  std::uint32_t mm_width = 0, mm_height = 0;
  std::vector<ModeInfo> modes;
  std::uint32_t possible_crtcs = 0;  // union over the connector's encoders, bit = CRTC index
};

struct Plane {
  std::uint32_t id = 0;
  std::uint32_t possible_crtcs = 0;
  std::vector<std::uint32_t> formats;  // fourcc codes
};

struct Resources {
  std::vector<std::uint32_t> connectors;
  std::vector<std::uint32_t> crtcs;    // in CRTC index order (possible_crtcs bits)
  std::vector<std::uint32_t> planes;
};

struct DumbBuffer {
  std::uint32_t handle = 0;
  std::uint32_t pitch = 0;
  std::uint64_t size = 0;
  std::uint32_t width = 0, height = 0, bpp = 0;
};

// An atomic request built by property name, with a sticky failure flag (wlroots'
// atomic.c): the first missing property or enum entry is remembered, later additions
// are ignored, and only the commit reports it.
class AtomicRequest {
 public:
  struct Item {
    std::uint32_t object = 0, property = 0;
    std::uint64_t value = 0;
    std::string name;
  };
  void add(std::uint32_t object, const Properties& props, std::string_view name, std::uint64_t value);
  void add_enum(std::uint32_t object, const Properties& props, std::string_view name, std::string_view entry);
  // For properties a driver may lack (e.g. "max bpc"): skipped without failing.
  bool add_if_present(std::uint32_t object, const Properties& props, std::string_view name, std::uint64_t value);
  bool failed() const { return !error_.empty(); }
  const std::string& error() const { return error_; }
  const std::vector<Item>& items() const { return items_; }
  std::optional<std::uint64_t> value_of(std::uint32_t object, std::string_view name) const;

 private:
  void fail(std::string message);
  std::vector<Item> items_;
  std::string error_;
};

// A page-flip event (struct drm_event_vblank): the commit with `user_data` took effect at
// vblank number `sequence` of `crtc_id`, at `timestamp_ns` on CLOCK_MONOTONIC (the clock
// DRM stamps events with when DRM_CAP_TIMESTAMP_MONOTONIC is 1, as on every kernel since 3.x).
struct FlipEvent {
  std::uint64_t user_data = 0;
  std::uint32_t crtc_id = 0;
  std::uint32_t sequence = 0;
  std::int64_t timestamp_ns = 0;
};

class KmsDevice {
 public:
  virtual ~KmsDevice() = default;
  virtual std::string path() const = 0;
  virtual std::string driver() const = 0;
  virtual Result<Resources> resources() = 0;
  virtual Result<Connector> connector(std::uint32_t id) = 0;
  virtual Result<Plane> plane(std::uint32_t id) = 0;
  virtual Result<Properties> properties(std::uint32_t object, std::uint32_t object_type) = 0;
  virtual Result<std::vector<std::uint8_t>> blob(std::uint32_t blob_id) = 0;
  virtual Result<std::uint32_t> create_blob(std::span<const std::uint8_t> bytes) = 0;
  virtual Result<std::uint32_t> create_mode_blob(const ModeInfo& mode) = 0;
  virtual void destroy_blob(std::uint32_t blob_id) = 0;
  virtual Result<DumbBuffer> create_dumb(std::uint32_t width, std::uint32_t height, std::uint32_t bpp) = 0;
  virtual Result<std::span<std::uint8_t>> map_dumb(const DumbBuffer& buffer) = 0;
  virtual void destroy_dumb(const DumbBuffer& buffer) = 0;
  virtual Result<std::uint32_t> add_fb2(std::uint32_t width, std::uint32_t height, std::uint32_t fourcc,
                                        std::uint32_t handle, std::uint32_t pitch) = 0;
  virtual void remove_fb(std::uint32_t fb_id) = 0;
  // Fails with the request's sticky error before reaching the kernel.
  virtual Result<void> atomic_commit(const AtomicRequest& request, std::uint32_t flags) = 0;
  // The same with DRM_MODE_PAGE_FLIP_EVENT: an event carrying `user_data` is queued on the
  // device when the commit takes effect. A nonblocking commit while one is still pending
  // on the CRTC fails with EBUSY (code kms.busy).
  virtual Result<void> atomic_commit_with_event(const AtomicRequest& request, std::uint32_t flags,
                                                std::uint64_t user_data) = 0;
  // Waits at most `timeout` for events and returns those that arrived (empty on timeout
  // or when a signal interrupted the wait).
  virtual Result<std::vector<FlipEvent>> read_flip_events(std::chrono::milliseconds timeout) = 0;
  // The clock flip events are stamped with (CLOCK_MONOTONIC), in ns. A fake device
  // simulates it.
  virtual std::int64_t now_ns() const;
};

}  // namespace hdrd::display::kms

#include "display/drm_device.hpp"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>
#include <unistd.h>

#include <drm_fourcc.h>
#include <drm_mode.h>
#include <xf86drm.h>
#include <xf86drmMode.h>

#include <fmt/format.h>

#include "display/hdr_metadata.hpp"

namespace hdrd::display {

using namespace kms;

// kms.hpp repeats these so it needs no libdrm; keep them honest.
static_assert(kObjectConnector == DRM_MODE_OBJECT_CONNECTOR);
static_assert(kObjectCrtc == DRM_MODE_OBJECT_CRTC);
static_assert(kObjectPlane == DRM_MODE_OBJECT_PLANE);
static_assert(kAtomicTestOnly == DRM_MODE_ATOMIC_TEST_ONLY);
static_assert(kPageFlipEvent == DRM_MODE_PAGE_FLIP_EVENT);
static_assert(kAtomicNonblock == DRM_MODE_ATOMIC_NONBLOCK);
static_assert(kAtomicAllowModeset == DRM_MODE_ATOMIC_ALLOW_MODESET);
static_assert(kModeTypePreferred == DRM_MODE_TYPE_PREFERRED);
static_assert(kConnectorTypeWriteback == DRM_MODE_CONNECTOR_WRITEBACK);
static_assert(sizeof(hdr_output_metadata) == kHdrOutputMetadataSize);
static_assert(offsetof(hdr_output_metadata, hdmi_metadata_type1) == 4);
static_assert(DRM_FORMAT_XBGR2101010 == 0x30334258 && DRM_FORMAT_ABGR16161616F == 0x48344241 &&
              DRM_FORMAT_XRGB8888 == 0x34325258);

namespace {

Error sys_error(const std::string& what, int err) {
  std::string msg = fmt::format("{}: {}", what, std::strerror(err));
  if (err == EACCES || err == EPERM)
    msg += " (hdrd must be DRM master to change the display: is a compositor or another client running?)";
  return make_error("kms.ioctl", msg);
}

ModeInfo from_drm(const drmModeModeInfo& m) {
  ModeInfo o;
  o.clock_khz = m.clock;
  o.hdisplay = m.hdisplay;
  o.hsync_start = m.hsync_start;
  o.hsync_end = m.hsync_end;
  o.htotal = m.htotal;
  o.hskew = m.hskew;
  o.vdisplay = m.vdisplay;
  o.vsync_start = m.vsync_start;
  o.vsync_end = m.vsync_end;
  o.vtotal = m.vtotal;
  o.vscan = m.vscan;
  o.vrefresh = m.vrefresh;
  o.flags = m.flags;
  o.type = m.type;
  o.name.assign(m.name, strnlen(m.name, sizeof m.name));
  return o;
}

drmModeModeInfo to_drm(const ModeInfo& m) {
  drmModeModeInfo o{};
  o.clock = m.clock_khz;
  o.hdisplay = m.hdisplay;
  o.hsync_start = m.hsync_start;
  o.hsync_end = m.hsync_end;
  o.htotal = m.htotal;
  o.hskew = m.hskew;
  o.vdisplay = m.vdisplay;
  o.vsync_start = m.vsync_start;
  o.vsync_end = m.vsync_end;
  o.vtotal = m.vtotal;
  o.vscan = m.vscan;
  o.vrefresh = m.vrefresh;
  o.flags = m.flags;
  o.type = m.type;
  std::strncpy(o.name, m.name.c_str(), sizeof o.name - 1);
  return o;
}

PropertyKind kind_of(drmModePropertyRes* p) {
  if (drm_property_type_is(p, DRM_MODE_PROP_SIGNED_RANGE)) return PropertyKind::signed_range;
  if (drm_property_type_is(p, DRM_MODE_PROP_ENUM)) return PropertyKind::enumeration;
  if (drm_property_type_is(p, DRM_MODE_PROP_BITMASK)) return PropertyKind::bitmask;
  if (drm_property_type_is(p, DRM_MODE_PROP_BLOB)) return PropertyKind::blob;
  if (drm_property_type_is(p, DRM_MODE_PROP_OBJECT)) return PropertyKind::object;
  return PropertyKind::range;
}

}  // namespace

std::vector<std::string> drm_card_paths() {
  std::vector<std::string> paths;
  const int n = drmGetDevices2(0, nullptr, 0);
  if (n <= 0) return paths;  // -ENOENT on a machine without /dev/dri
  std::vector<drmDevicePtr> devices(static_cast<std::size_t>(n));
  const int got = drmGetDevices2(0, devices.data(), n);
  for (int i = 0; i < got; ++i)
    if (devices[i]->available_nodes & (1 << DRM_NODE_PRIMARY)) paths.emplace_back(devices[i]->nodes[DRM_NODE_PRIMARY]);
  if (got > 0) drmFreeDevices(devices.data(), got);
  return paths;
}

Result<std::unique_ptr<DrmDevice>> DrmDevice::open(const std::string& path, bool writeback) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    Error err = sys_error("cannot open " + path, e);
    if (e == EACCES) err.message = fmt::format("cannot open {}: {} (is the user in the 'video' group?)", path, std::strerror(e));
    return err;
  }
  std::unique_ptr<DrmDevice> d(new DrmDevice(fd, path));
  if (drmVersionPtr v = drmGetVersion(fd)) {
    d->driver_.assign(v->name, static_cast<std::size_t>(v->name_len));
    drmFreeVersion(v);
  }
  drmSetClientCap(fd, DRM_CLIENT_CAP_UNIVERSAL_PLANES, 1);
  d->atomic_ = drmSetClientCap(fd, DRM_CLIENT_CAP_ATOMIC, 1) == 0;
  if (writeback && d->atomic_) drmSetClientCap(fd, DRM_CLIENT_CAP_WRITEBACK_CONNECTORS, 1);
  return d;
}

DrmDevice::~DrmDevice() {
  for (auto& [handle, m] : mappings_) munmap(m.first, m.second);
  if (fd_ >= 0) ::close(fd_);
}

Result<Resources> DrmDevice::resources() {
  drmModeRes* r = drmModeGetResources(fd_);
  if (!r) return make_error("kms.not_kms", fmt::format("{} ({}) is not a KMS device", path_, driver_));
  Resources out;
  out.connectors.assign(r->connectors, r->connectors + r->count_connectors);
  out.crtcs.assign(r->crtcs, r->crtcs + r->count_crtcs);
  drmModeFreeResources(r);
  if (drmModePlaneRes* p = drmModeGetPlaneResources(fd_)) {
    out.planes.assign(p->planes, p->planes + p->count_planes);
    drmModeFreePlaneResources(p);
  }
  return out;
}

Result<Connector> DrmDevice::connector(std::uint32_t id) {
  drmModeConnector* c = drmModeGetConnector(fd_, id);  // probes: fresh status and modes
  if (!c) return sys_error(fmt::format("connector {}", id), errno);
  Connector out;
  out.id = c->connector_id;
  out.type = c->connector_type;
  out.type_id = c->connector_type_id;
  const char* type_name = drmModeGetConnectorTypeName(c->connector_type);
  out.name = fmt::format("{}-{}", type_name ? type_name : "Unknown", c->connector_type_id);
  out.status = c->connection == DRM_MODE_CONNECTED      ? ConnectionStatus::connected
               : c->connection == DRM_MODE_DISCONNECTED ? ConnectionStatus::disconnected
                                                        : ConnectionStatus::unknown;
  out.mm_width = c->mmWidth;
  out.mm_height = c->mmHeight;
  for (int i = 0; i < c->count_modes; ++i) out.modes.push_back(from_drm(c->modes[i]));
  for (int i = 0; i < c->count_encoders; ++i)
    if (drmModeEncoder* e = drmModeGetEncoder(fd_, c->encoders[i])) {
      out.possible_crtcs |= e->possible_crtcs;
      drmModeFreeEncoder(e);
    }
  drmModeFreeConnector(c);
  return out;
}

Result<Plane> DrmDevice::plane(std::uint32_t id) {
  drmModePlane* p = drmModeGetPlane(fd_, id);
  if (!p) return sys_error(fmt::format("plane {}", id), errno);
  Plane out{p->plane_id, p->possible_crtcs, {p->formats, p->formats + p->count_formats}};
  drmModeFreePlane(p);
  return out;
}

Result<Properties> DrmDevice::properties(std::uint32_t object, std::uint32_t object_type) {
  drmModeObjectProperties* props = drmModeObjectGetProperties(fd_, object, object_type);
  if (!props) return sys_error(fmt::format("properties of object {}", object), errno);
  Properties out;
  for (std::uint32_t i = 0; i < props->count_props; ++i) {
    drmModePropertyRes* p = drmModeGetProperty(fd_, props->props[i]);
    if (!p) continue;
    Property prop;
    prop.id = p->prop_id;
    prop.name = p->name;
    prop.kind = kind_of(p);
    prop.value = props->prop_values[i];
    prop.immutable = p->flags & DRM_MODE_PROP_IMMUTABLE;
    for (int e = 0; e < p->count_enums; ++e) prop.enums.emplace_back(p->enums[e].name, p->enums[e].value);
    if ((prop.kind == PropertyKind::range || prop.kind == PropertyKind::signed_range) && p->count_values >= 2) {
      prop.min = p->values[0];
      prop.max = p->values[1];
    }
    out.push_back(std::move(prop));
    drmModeFreeProperty(p);
  }
  drmModeFreeObjectProperties(props);
  return out;
}

Result<std::vector<std::uint8_t>> DrmDevice::blob(std::uint32_t blob_id) {
  drmModePropertyBlobRes* b = drmModeGetPropertyBlob(fd_, blob_id);
  if (!b) return sys_error(fmt::format("blob {}", blob_id), errno);
  const auto* data = static_cast<const std::uint8_t*>(b->data);
  std::vector<std::uint8_t> out(data, data + b->length);
  drmModeFreePropertyBlob(b);
  return out;
}

Result<std::uint32_t> DrmDevice::create_blob(std::span<const std::uint8_t> bytes) {
  std::uint32_t id = 0;
  if (int r = drmModeCreatePropertyBlob(fd_, bytes.data(), bytes.size(), &id); r != 0)
    return sys_error("create property blob", -r > 0 ? -r : errno);
  return id;
}

Result<std::uint32_t> DrmDevice::create_mode_blob(const ModeInfo& mode) {
  const drmModeModeInfo m = to_drm(mode);
  return create_blob({reinterpret_cast<const std::uint8_t*>(&m), sizeof m});
}

void DrmDevice::destroy_blob(std::uint32_t blob_id) { drmModeDestroyPropertyBlob(fd_, blob_id); }

Result<DumbBuffer> DrmDevice::create_dumb(std::uint32_t width, std::uint32_t height, std::uint32_t bpp) {
  DumbBuffer d;
  d.width = width;
  d.height = height;
  d.bpp = bpp;
  if (int r = drmModeCreateDumbBuffer(fd_, width, height, bpp, 0, &d.handle, &d.pitch, &d.size); r != 0)
    return sys_error(fmt::format("create {}x{} {}-bpp dumb buffer", width, height, bpp), -r > 0 ? -r : errno);
  return d;
}

Result<std::span<std::uint8_t>> DrmDevice::map_dumb(const DumbBuffer& d) {
  std::uint64_t offset = 0;
  if (int r = drmModeMapDumbBuffer(fd_, d.handle, &offset); r != 0)
    return sys_error("map dumb buffer", -r > 0 ? -r : errno);
  void* p = mmap(nullptr, d.size, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, static_cast<off_t>(offset));
  if (p == MAP_FAILED) return sys_error("mmap dumb buffer", errno);
  mappings_[d.handle] = {p, d.size};
  return std::span<std::uint8_t>(static_cast<std::uint8_t*>(p), d.size);
}

void DrmDevice::destroy_dumb(const DumbBuffer& d) {
  if (auto it = mappings_.find(d.handle); it != mappings_.end()) {
    munmap(it->second.first, it->second.second);
    mappings_.erase(it);
  }
  drmModeDestroyDumbBuffer(fd_, d.handle);
}

Result<std::uint32_t> DrmDevice::add_fb2(std::uint32_t width, std::uint32_t height, std::uint32_t fourcc,
                                         std::uint32_t handle, std::uint32_t pitch) {
  const std::uint32_t handles[4] = {handle, 0, 0, 0}, pitches[4] = {pitch, 0, 0, 0}, offsets[4] = {0, 0, 0, 0};
  std::uint32_t id = 0;
  if (drmModeAddFB2(fd_, width, height, fourcc, handles, pitches, offsets, &id, 0) != 0)
    return sys_error(fmt::format("add {}x{} framebuffer", width, height), errno);
  return id;
}

void DrmDevice::remove_fb(std::uint32_t fb_id) { drmModeRmFB(fd_, fb_id); }

Result<void> DrmDevice::atomic_commit(const AtomicRequest& request, std::uint32_t flags) {
  return commit(request, flags, nullptr);
}

Result<void> DrmDevice::atomic_commit_with_event(const AtomicRequest& request, std::uint32_t flags,
                                                 std::uint64_t user_data) {
  return commit(request, flags | DRM_MODE_PAGE_FLIP_EVENT, reinterpret_cast<void*>(static_cast<std::uintptr_t>(user_data)));
}

Result<void> DrmDevice::commit(const AtomicRequest& request, std::uint32_t flags, void* user_data) {
  if (request.failed()) return make_error("kms.request", request.error());
  if (!atomic_) return make_error("kms.no_atomic", fmt::format("{} ({}) has no atomic modesetting", path_, driver_));
  drmModeAtomicReq* req = drmModeAtomicAlloc();
  if (!req) return make_error("kms.atomic", "out of memory for an atomic request");
  for (const auto& item : request.items()) {
    if (drmModeAtomicAddProperty(req, item.object, item.property, item.value) < 0) {
      drmModeAtomicFree(req);
      return make_error("kms.atomic", fmt::format("cannot add \"{}\" to the atomic request", item.name));
    }
  }
  const int r = drmModeAtomicCommit(fd_, req, flags, user_data);
  const int err = r < -1 ? -r : errno;
  drmModeAtomicFree(req);
  if (r != 0) {
    Error e = sys_error("atomic commit", err);
    e.code = err == EBUSY ? "kms.busy" : "kms.atomic";
    e.message = e.message.substr(std::string("atomic commit: ").size());
    return e;
  }
  return {};
}

namespace {
thread_local std::vector<FlipEvent>* flip_sink = nullptr;  // drmHandleEvent's handlers get no context
void on_page_flip(int, unsigned sequence, unsigned sec, unsigned usec, unsigned crtc_id, void* user_data) {
  if (flip_sink)
    flip_sink->push_back({static_cast<std::uint64_t>(reinterpret_cast<std::uintptr_t>(user_data)), crtc_id, sequence,
                          std::int64_t(sec) * 1'000'000'000 + std::int64_t(usec) * 1000});
}
}  // namespace

Result<std::vector<FlipEvent>> DrmDevice::read_flip_events(std::chrono::milliseconds timeout) {
  std::vector<FlipEvent> events;
  pollfd p{fd_, POLLIN, 0};
  const int n = poll(&p, 1, static_cast<int>(std::max<std::int64_t>(0, timeout.count())));
  if (n < 0 && errno != EINTR) return sys_error("poll on " + path_, errno);
  if (n <= 0) return events;
  drmEventContext ctx{};
  ctx.version = 3;  // page_flip_handler2: with the CRTC id
  ctx.page_flip_handler2 = on_page_flip;
  flip_sink = &events;
  const int r = drmHandleEvent(fd_, &ctx);
  flip_sink = nullptr;
  if (r != 0) return sys_error("reading DRM events from " + path_, errno);
  return events;
}

}  // namespace hdrd::display

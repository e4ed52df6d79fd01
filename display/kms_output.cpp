#include "display/kms_output.hpp"

#include <algorithm>
#include <cstring>
#include <optional>

#include <fmt/format.h>

namespace hdrd::display {

using namespace kms;

namespace {

Error wrap(const Error& e, const std::string& prefix) {
  Error out = e;
  out.message = prefix + ": " + e.message;
  return out;
}

ModeInfo pick_mode(const Connector& c, int width, int height) {
  // A mode of the frame's own size avoids scaling; among those the preferred one, then the
  // fastest. Otherwise the preferred mode (the frame is placed top-left).
  const ModeInfo* best = nullptr;
  for (const auto& m : c.modes) {
    if (m.hdisplay != width || m.vdisplay != height) continue;
    if (!best || (m.preferred() && !best->preferred()) ||
        (m.preferred() == best->preferred() && m.refresh_hz() > best->refresh_hz()))
      best = &m;
  }
  if (best) return *best;
  for (const auto& m : c.modes)
    if (m.preferred()) return m;
  return c.modes.front();
}

struct CrtcChoice {
  std::uint32_t id = 0;
  int index = 0;
};

Result<CrtcChoice> pick_crtc(const Resources& res, const Connector& c, const Properties& conn_props) {
  // Keep the CRTC the connector already drives, if any, so no other output is disturbed.
  if (const Property* p = find_property(conn_props, "CRTC_ID"); p && p->value)
    for (std::size_t i = 0; i < res.crtcs.size() && i < 32; ++i)
      if (res.crtcs[i] == p->value && (c.possible_crtcs & (1u << i))) return CrtcChoice{res.crtcs[i], int(i)};
  for (std::size_t i = 0; i < res.crtcs.size() && i < 32; ++i)
    if (c.possible_crtcs & (1u << i)) return CrtcChoice{res.crtcs[i], int(i)};
  return make_error("kms.no_crtc", fmt::format("no CRTC can drive connector {}", c.name), "connector");
}

struct PlaneChoice {
  std::uint32_t id = 0;
  Properties props;
};

Result<PlaneChoice> pick_plane(KmsDevice& dev, const Resources& res, int crtc_index, std::uint32_t fourcc) {
  std::vector<std::string> offered;
  for (std::uint32_t id : res.planes) {
    auto plane = dev.plane(id);
    if (!plane) return plane.error();
    if (!(plane->possible_crtcs & (1u << crtc_index))) continue;
    auto props = dev.properties(id, kObjectPlane);
    if (!props) return props.error();
    const Property* type = find_property(*props, "type");
    if (!type || type->enum_value("Primary") != type->value) continue;
    if (std::find(plane->formats.begin(), plane->formats.end(), fourcc) != plane->formats.end())
      return PlaneChoice{id, std::move(*props)};
    for (auto f : plane->formats) offered.push_back(fourcc_name(f));
  }
  return make_error("kms.format", fmt::format("no primary plane for the CRTC scans out {} (offered: {})", fourcc_name(fourcc),
                                              offered.empty() ? "nothing" : fmt::format("{}", fmt::join(offered, " "))),
                    "fourcc");
}

bool ten_bit_or_more(std::uint32_t fourcc) { return fourcc != kDrmFormatXrgb8888; }

}  // namespace

namespace {

bool signals_hdr(KmsDevice& dev, const Connector& c) {
  auto props = dev.properties(c.id, kObjectConnector);
  return props && find_property(*props, "HDR_OUTPUT_METADATA") && find_property(*props, "Colorspace");
}

}  // namespace

Result<Connector> pick_connector(KmsDevice& dev, const std::string& name, bool prefer_hdr) {
  auto res = dev.resources();
  if (!res) return res.error();
  std::vector<std::string> seen;
  std::optional<Connector> first;
  for (std::uint32_t id : res->connectors) {
    auto c = dev.connector(id);
    if (!c) return c.error();
    if (c->type == kConnectorTypeWriteback) continue;
    if (!name.empty() && c->name != name) {
      seen.push_back(c->name);
      continue;
    }
    const bool usable = c->status == ConnectionStatus::connected && !c->modes.empty();
    if (usable && (!name.empty() || !prefer_hdr || signals_hdr(dev, *c))) return std::move(*c);
    if (usable && !first) first = *c;
    if (!name.empty())
      return make_error("kms.no_display", fmt::format("no display attached to {} on {} ({}, {} modes)", name, dev.path(),
                                                      to_string(c->status), c->modes.size()), "connector");
    if (!usable) seen.push_back(fmt::format("{} {}", c->name, to_string(c->status)));
  }
  if (first) return std::move(*first);  // no HDR-capable one: the first connected display
  if (!name.empty())
    return make_error("kms.no_connector", fmt::format("{} has no connector {} (it has: {})", dev.path(), name,
                                                      seen.empty() ? "none" : fmt::format("{}", fmt::join(seen, ", "))),
                      "connector");
  return make_error("kms.no_display", fmt::format("no display attached: no connected connector on {} ({})", dev.path(),
                                                  seen.empty() ? "no connectors" : fmt::format("{}", fmt::join(seen, ", "))));
}

KmsOutput::~KmsOutput() { release(); }

void KmsOutput::release() {
  if (fb_) device_.remove_fb(fb_);
  fb_ = 0;
  if (dumb_) device_.destroy_dumb(*dumb_);
  dumb_.reset();
  for (auto b : blobs_) device_.destroy_blob(b);
  blobs_.clear();
}

void fill_black(std::span<std::uint8_t> buf, std::uint32_t fourcc) {
  std::fill(buf.begin(), buf.end(), 0);
  if (fourcc != kDrmFormatAbgr16161616f) return;
  for (std::size_t i = 6; i + 1 < buf.size(); i += 8) {
    buf[i] = 0x00;
    buf[i + 1] = 0x3c;
  }
}

void copy_frame(const EncodedFrame& f, const DumbBuffer& d, std::span<std::uint8_t> map) {
  const std::size_t bytes_pp = static_cast<std::size_t>(scanout_bytes_per_pixel(f.drm_fourcc));
  const std::size_t rows = std::min<std::size_t>(f.height, d.height);
  const std::size_t row_bytes = std::min<std::size_t>(f.width, d.width) * bytes_pp;
  for (std::size_t y = 0; y < rows; ++y)
    std::memcpy(map.data() + y * d.pitch, f.data.data() + y * f.stride_bytes, row_bytes);
}

std::optional<std::string> fit_note(const EncodedFrame& f, const ModeInfo& m) {
  if (f.width == m.hdisplay && f.height == m.vdisplay) return std::nullopt;
  return fmt::format("frame {}x{} shown top-left in mode {}x{} ({})", f.width, f.height, m.hdisplay, m.vdisplay,
                     f.width > m.hdisplay || f.height > m.vdisplay ? "cropped" : "black border");
}

// A dumb buffer at the mode's size holding the frame top-left (cropped or padded black).
Result<void> KmsOutput::upload(const EncodedFrame& f, PresentResult& out) {
  const int bytes_pp = scanout_bytes_per_pixel(f.drm_fourcc);
  auto dumb = device_.create_dumb(out.mode.hdisplay, out.mode.vdisplay, static_cast<std::uint32_t>(bytes_pp * 8));
  if (!dumb) return wrap(dumb.error(), "cannot allocate a scan-out buffer");
  dumb_ = *dumb;
  auto map = device_.map_dumb(*dumb_);
  if (!map) return wrap(map.error(), "cannot map the scan-out buffer");
  fill_black(*map, f.drm_fourcc);
  copy_frame(f, *dumb_, *map);
  if (auto note = fit_note(f, out.mode)) out.notes.push_back(*note);
  auto fb = device_.add_fb2(dumb_->width, dumb_->height, f.drm_fourcc, dumb_->handle, dumb_->pitch);
  if (!fb) return wrap(fb.error(), fmt::format("cannot create a {} framebuffer", fourcc_name(f.drm_fourcc)));
  fb_ = *fb;
  out.fb_id = fb_;
  return {};
}

// HDR_OUTPUT_METADATA, Colorspace and max bpc for the signal (REFERENCE.md §6).
Result<void> add_signalling(KmsDevice& device, const EncodedFrame& f, const ContentLightLevel& light,
                            const OutputRoute& route, const PresentOptions& opt, AtomicRequest& req,
                            PresentResult& out, std::vector<std::uint32_t>& blobs) {
  const Connector& c = route.connector;
  const Properties& props = route.connector_props;
  const bool hdr = f.target.mode == Mode::hdr10 || f.target.mode == Mode::hlg;
  const bool has_meta = find_property(props, "HDR_OUTPUT_METADATA");
  const bool has_colorspace = find_property(props, "Colorspace");
  if (hdr && (!has_meta || !has_colorspace)) {
    const std::string missing = !has_meta ? "HDR_OUTPUT_METADATA" : "Colorspace";
    if (opt.require_hdr_properties)
      return make_error("kms.no_hdr", fmt::format("connector {} has no {} property, so the display would show the {} "
                                                  "signal as SDR", c.name, missing, to_string(f.target.mode)),
                        "connector");
    out.notes.push_back(fmt::format("connector {} has no {} property: the {} signal is sent unsignalled", c.name,
                                    missing, to_string(f.target.mode)));
  }
  if (hdr && has_meta) {
    auto meta = make_hdr_output_metadata(f.target.mode, f.mastering, light);
    if (!meta) return meta.error();
    const auto bytes = serialize(*meta);
    auto blob = device.create_blob(bytes);
    if (!blob) return wrap(blob.error(), "HDR_OUTPUT_METADATA blob");
    blobs.push_back(*blob);
    req.add(c.id, props, "HDR_OUTPUT_METADATA", *blob);
    out.hdr_metadata = *meta;
  } else if (has_meta) {
    req.add(c.id, props, "HDR_OUTPUT_METADATA", 0);  // clear a previous HDR state
  }
  if (has_colorspace) {
    out.colorspace = std::string(colorspace_name(f.target.mode));
    req.add_enum(c.id, props, "Colorspace", out.colorspace);
  }
  if (const Property* bpc = find_property(props, "max bpc"); bpc && ten_bit_or_more(f.drm_fourcc)) {
    const std::uint64_t want = std::clamp<std::uint64_t>(10, bpc->min, std::max(bpc->min, bpc->max));
    if (want < 10) out.notes.push_back(fmt::format("connector {} allows at most {} bpc on the link", c.name, want));
    req.add(c.id, props, "max bpc", want);
    out.max_bpc = want;
  }
  return {};
}

Result<OutputRoute> plan_route(KmsDevice& device, const EncodedFrame& f, const PresentOptions& opt) {
  const bool hdr = f.target.mode == Mode::hdr10 || f.target.mode == Mode::hlg;
  OutputRoute r;
  auto conn = pick_connector(device, opt.connector, hdr);
  if (!conn) return conn.error();
  r.connector = std::move(*conn);
  auto res = device.resources();
  if (!res) return res.error();
  auto conn_props = device.properties(r.connector.id, kObjectConnector);
  if (!conn_props) return conn_props.error();
  r.connector_props = std::move(*conn_props);
  auto crtc = pick_crtc(*res, r.connector, r.connector_props);
  if (!crtc) return crtc.error();
  auto crtc_props = device.properties(crtc->id, kObjectCrtc);
  if (!crtc_props) return crtc_props.error();
  r.crtc_id = crtc->id;
  r.crtc_props = std::move(*crtc_props);
  auto plane = pick_plane(device, *res, crtc->index, f.drm_fourcc);
  if (!plane) return plane.error();
  r.plane_id = plane->id;
  r.plane_props = std::move(plane->props);
  r.mode = pick_mode(r.connector, f.width, f.height);
  return r;
}

void add_modeset(const OutputRoute& r, std::uint32_t mode_blob, AtomicRequest& req) {
  req.add(r.connector.id, r.connector_props, "CRTC_ID", r.crtc_id);
  req.add(r.crtc_id, r.crtc_props, "MODE_ID", mode_blob);
  req.add(r.crtc_id, r.crtc_props, "ACTIVE", 1);
  const std::uint64_t w = r.mode.hdisplay, h = r.mode.vdisplay;
  req.add(r.plane_id, r.plane_props, "CRTC_ID", r.crtc_id);
  req.add(r.plane_id, r.plane_props, "SRC_X", 0);
  req.add(r.plane_id, r.plane_props, "SRC_Y", 0);
  req.add(r.plane_id, r.plane_props, "SRC_W", w << 16);  // 16.16 fixed point
  req.add(r.plane_id, r.plane_props, "SRC_H", h << 16);
  req.add(r.plane_id, r.plane_props, "CRTC_X", 0);
  req.add(r.plane_id, r.plane_props, "CRTC_Y", 0);
  req.add(r.plane_id, r.plane_props, "CRTC_W", w);
  req.add(r.plane_id, r.plane_props, "CRTC_H", h);
}

void add_flip(const OutputRoute& r, std::uint32_t fb_id, AtomicRequest& req) {
  req.add(r.plane_id, r.plane_props, "FB_ID", fb_id);
}

void add_disable(const OutputRoute& r, AtomicRequest& req) {
  req.add(r.plane_id, r.plane_props, "FB_ID", 0);
  req.add(r.plane_id, r.plane_props, "CRTC_ID", 0);
  req.add(r.crtc_id, r.crtc_props, "ACTIVE", 0);
  req.add(r.crtc_id, r.crtc_props, "MODE_ID", 0);
  req.add(r.connector.id, r.connector_props, "CRTC_ID", 0);
  req.add_if_present(r.connector.id, r.connector_props, "HDR_OUTPUT_METADATA", 0);
}

Result<PresentResult> KmsOutput::show(const EncodedFrame& input, const PresentOptions& opt) {
  auto prepared = prepare_for_scanout(input, opt.scrgb);
  if (!prepared) return prepared.error();
  const EncodedFrame& f = prepared->frame;
  PresentResult out;
  out.device = device_.path();
  out.notes = prepared->notes;
  out.fourcc = f.drm_fourcc;
  out.signal = f.target.mode;

  auto route = plan_route(device_, f, opt);
  if (!route) return route.error();
  out.connector = route->connector.name;
  out.crtc_id = route->crtc_id;
  out.plane_id = route->plane_id;
  out.mode = route->mode;

  release();  // the previous frame's buffers, now that the new one can be set up
  if (auto up = upload(f, out); !up) return up.error();

  AtomicRequest req;
  auto mode_blob = device_.create_mode_blob(out.mode);
  if (!mode_blob) return wrap(mode_blob.error(), "MODE_ID blob");
  blobs_.push_back(*mode_blob);
  add_modeset(*route, *mode_blob, req);
  add_flip(*route, fb_, req);
  if (auto sig = add_signalling(device_, f, f.content_light, *route, opt, req, out, blobs_); !sig) return sig.error();

  if (auto t = device_.atomic_commit(req, kAtomicTestOnly | kAtomicAllowModeset); !t)
    return wrap(t.error(), fmt::format("{} rejected the configuration in a TEST_ONLY commit", out.device));
  if (opt.test_only) return out;
  if (auto c = device_.atomic_commit(req, kAtomicAllowModeset); !c)
    return wrap(c.error(), fmt::format("atomic commit on {} failed", out.device));
  out.committed = true;
  return out;
}

}  // namespace hdrd::display

#include "display/displays.hpp"

#include <fmt/format.h>

#include "display/drm_device.hpp"
#include "display/edid_json.hpp"

namespace hdrd::display {

using namespace kms;
using nlohmann::json;

bool ConnectorReport::hdr_capable() const {
  return connected() && profile && profile->is_hdr() && has_hdr_output_metadata && !colorspaces.empty();
}

namespace {

void read_edid(KmsDevice& dev, const Property* edid_prop, const std::vector<ProfileOverride>& overrides,
               ConnectorReport& r) {
  if (!edid_prop || edid_prop->value == 0) {
    if (r.connected()) r.edid_error = "the connector has no EDID";
    return;
  }
  auto bytes = dev.blob(static_cast<std::uint32_t>(edid_prop->value));
  if (!bytes) {
    r.edid_error = bytes.error().message;
    return;
  }
  auto info = parse_edid(*bytes);
  if (!info) {
    r.edid_error = info.error().message;
    return;
  }
  auto profile = apply_matching_overrides(profile_from_edid_info(*info), overrides);
  if (profile) r.profile = std::move(*profile);
  else r.edid_error = profile.error().message;
  r.edid = std::move(*info);
}

}  // namespace

Result<std::vector<ConnectorReport>> describe_connectors(KmsDevice& dev, const std::vector<ProfileOverride>& overrides) {
  auto res = dev.resources();
  if (!res) return res.error();
  std::vector<ConnectorReport> out;
  for (std::uint32_t id : res->connectors) {
    auto c = dev.connector(id);
    if (!c) return c.error();
    if (c->type == kConnectorTypeWriteback) continue;
    ConnectorReport r;
    r.device = dev.path();
    r.driver = dev.driver();
    r.connector = std::move(*c);
    auto props = dev.properties(id, kObjectConnector);
    if (!props) return props.error();
    r.has_hdr_output_metadata = find_property(*props, "HDR_OUTPUT_METADATA") != nullptr;
    if (const Property* cs = find_property(*props, "Colorspace"))
      for (const auto& e : cs->enums) r.colorspaces.push_back(e.first);
    if (const Property* bpc = find_property(*props, "max bpc")) {
      r.max_bpc_range = std::make_pair(bpc->min, bpc->max);
      r.max_bpc = bpc->value;
    }
    read_edid(dev, find_property(*props, "EDID"), overrides, r);
    out.push_back(std::move(r));
  }
  return out;
}

DisplaysReport enumerate_displays(const std::vector<ProfileOverride>& overrides) {
  DisplaysReport report;
  report.devices = drm_card_paths();
  if (report.devices.empty()) {
    report.note = "no DRM devices (drmGetDevices2 found none: a headless machine): no display is attached";
    return report;
  }
  for (const auto& path : report.devices) {
    auto dev = DrmDevice::open(path);
    if (!dev) {
      report.errors.push_back(dev.error().message);
      continue;
    }
    auto conns = describe_connectors(**dev, overrides);
    if (!conns) {
      report.errors.push_back(fmt::format("{}: {}", path, conns.error().message));
      continue;
    }
    for (auto& c : *conns) report.connectors.push_back(std::move(c));
  }
  bool any = false;
  for (const auto& c : report.connectors) any = any || c.connected();
  if (!any) report.note = "no connected display on any DRM device";
  return report;
}

std::optional<Profile> choose_auto_profile(const DisplaysReport& report) {
  for (const auto& c : report.connectors)
    if (c.hdr_capable()) return c.profile;
  for (const auto& c : report.connectors)
    if (c.connected() && c.profile) return c.profile;
  return std::nullopt;
}

Result<std::vector<ProfileOverride>> load_default_overrides() {
  std::vector<ProfileOverride> all;
  for (const auto& dir : default_profile_dirs()) {
    auto list = load_profile_overrides(dir);
    if (!list) return list.error();
    for (auto& o : *list) all.push_back(std::move(o));
  }
  return all;
}

Result<std::optional<Profile>> auto_profile() { return select_profile("auto", ""); }

namespace {

Result<std::optional<Profile>> connector_profile(const std::string& name, const std::vector<ProfileOverride>& overrides) {
  const DisplaysReport report = enumerate_displays(overrides);
  for (const auto& c : report.connectors) {
    if (c.connector.name != name) continue;
    if (!c.connected()) return make_error("display.not_connected", fmt::format("no display attached to {}", name), "display");
    if (!c.profile)
      return make_error("display.no_edid", fmt::format("{}: {}", name, c.edid_error.value_or("no EDID")), "display");
    return std::optional<Profile>(*c.profile);
  }
  if (report.devices.empty())
    return make_error("display.none", fmt::format("no display attached: no DRM devices, so no connector {}", name), "display");
  return make_error("display.unknown", fmt::format("no connector named {} (see 'hdrd displays')", name), "display");
}

}  // namespace

Result<std::optional<Profile>> select_profile(const std::string& display, const std::string& edid_path,
                                              const std::string& override_file, const io::InputFiles& files) {
  auto overrides = load_default_overrides();
  if (!overrides) return overrides.error();
  std::optional<Profile> p;
  if (!edid_path.empty()) {
    auto fromfile = profile_from_edid_file(edid_path, files);
    if (!fromfile) return fromfile.error();
    auto applied = apply_matching_overrides(std::move(*fromfile), *overrides);
    if (!applied) return applied.error();
    p = std::move(*applied);
  } else if (display == "auto") {
    const DisplaysReport report = enumerate_displays(*overrides);
    p = choose_auto_profile(report);
    if (!p && !report.errors.empty())
      return make_error("display.auto", "--display auto: " + report.errors.front(), "display");
  } else if (!display.empty()) {
    auto c = connector_profile(display, *overrides);
    if (!c) return c.error();
    p = std::move(*c);
  }
  if (!override_file.empty()) {
    auto o = load_profile_override(override_file, files);
    if (!o) return o.error();
    auto applied = apply_override(p ? std::move(*p) : Profile{}, *o);
    if (!applied) return applied.error();
    p = std::move(*applied);
  }
  return p;
}

json to_json(const ConnectorReport& c) {
  json modes = json::array();
  for (const auto& m : c.connector.modes)
    modes.push_back({{"width", m.hdisplay}, {"height", m.vdisplay}, {"refresh_hz", m.refresh_hz()},
                     {"preferred", m.preferred()}, {"name", m.name}});
  json j = {{"device", c.device},
            {"driver", c.driver},
            {"connector", c.connector.name},
            {"connector_id", c.connector.id},
            {"status", std::string(to_string(c.connector.status))},
            {"physical_size_mm", json::array({c.connector.mm_width, c.connector.mm_height})},
            {"modes", modes},
            {"properties",
             {{"HDR_OUTPUT_METADATA", c.has_hdr_output_metadata},
              {"Colorspace", c.colorspaces},
              {"max_bpc", c.max_bpc ? json(*c.max_bpc) : json(nullptr)},
              {"max_bpc_range", c.max_bpc_range ? json::array({c.max_bpc_range->first, c.max_bpc_range->second})
                                                : json(nullptr)}}},
            {"hdr_capable", c.hdr_capable()},
            {"edid", c.edid ? edid_to_json(*c.edid) : json(nullptr)},
            {"edid_error", c.edid_error ? json(*c.edid_error) : json(nullptr)},
            {"profile", c.profile ? profile_to_json(*c.profile) : json(nullptr)}};
  return j;
}

json to_json(const DisplaysReport& r) {
  json conns = json::array();
  for (const auto& c : r.connectors) conns.push_back(to_json(c));
  return {{"devices", r.devices}, {"connectors", conns}, {"errors", r.errors},
          {"note", r.note.empty() ? json(nullptr) : json(r.note)}};
}

}  // namespace hdrd::display

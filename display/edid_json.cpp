#include "display/edid_json.hpp"

#include <fmt/format.h>

namespace hdrd::display {
namespace {

using nlohmann::json;

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }
json optional_cv(const std::optional<std::uint8_t>& v) { return v ? json(int(*v)) : json(nullptr); }
json xy(color::Chromaticity c) { return json::array({c.x, c.y}); }
json raw_xy(RawXy c) { return json::array({c.x, c.y}); }

json timing_to_json(const DetailedTiming& t) {
  return {{"width", t.h_active},
          {"height", t.v_active},
          {"refresh_hz", t.refresh_hz()},
          {"pixel_clock_khz", t.pixel_clock_khz},
          {"interlaced", t.interlaced},
          {"image_size_mm", json::array({t.width_mm, t.height_mm})}};
}

json chromaticity_json(const EdidChromaticity& c) {
  const auto p = c.primaries();
  return {{"red", xy(p.red)}, {"green", xy(p.green)}, {"blue", xy(p.blue)}, {"white", xy(p.white)}};
}

json chromaticity_raw_json(const EdidChromaticity& c) {
  return {{"red", raw_xy(c.red)}, {"green", raw_xy(c.green)}, {"blue", raw_xy(c.blue)}, {"white", raw_xy(c.white)}};
}

json displayid_parameters_json(const DisplayIdDisplayParameters& d) {
  json prim = {{"red", xy(d.primaries.red)},
               {"green", xy(d.primaries.green)},
               {"blue", xy(d.primaries.blue)},
               {"white", xy(d.primaries.white)}};
  return {{"block", d.block_index},
          {"image_size_mm", json::array({d.size_in_mm ? d.width_raw : d.width_raw / 10.0,
                                          d.size_in_mm ? d.height_raw : d.height_raw / 10.0})},
          {"native_pixels", json::array({d.h_pixels, d.v_pixels})},
          {"luminance_information", d.luminance_info() == 0   ? "minimum guaranteed value"
                                    : d.luminance_info() == 1 ? "guidance for the source device"
                                                              : "reserved"},
          {"chromaticity", prim},
          {"native_max_luminance_full_cd_m2", d.max_full_cd_m2()},
          {"native_max_luminance_10pct_cd_m2", d.max_10pct_cd_m2()},
          {"native_min_luminance_cd_m2", d.min_cd_m2()},
          {"color_depth_bpc", d.color_depth_bpc() ? json(*d.color_depth_bpc()) : json(nullptr)},
          {"device_technology", d.device_technology() == 1   ? "AMLCD"
                                : d.device_technology() == 2 ? "AMOLED"
                                                             : "unspecified"},
          {"gamma", optional_number(d.gamma)}};
}

json displayid_json(const EdidInfo& info) {
  json sections = json::array();
  for (const auto& s : info.displayid) {
    json blocks = json::array();
    for (const auto& db : s.data_blocks) blocks.push_back(db.name);
    sections.push_back({{"block", s.block_index}, {"version", s.version_string()}, {"data_blocks", blocks}});
  }
  return sections;
}

json made_in(const EdidInfo& info) {
  return {{"week", info.model_year || !info.manufacture_week ? json(nullptr) : json(info.manufacture_week)},
          {"year", info.manufacture_year},
          {"model_year", info.model_year}};
}

}  // namespace

std::vector<std::string> colorimetry_names(const Colorimetry& c) {
  std::vector<std::string> out;
  for (auto& n : c.names())
    if (n.rfind("Reserved", 0) != 0) out.push_back(std::move(n));
  return out;
}

json hdr_static_metadata_to_json(const HdrStaticMetadata& h) {
  json eotfs = json::array();
  if (h.sdr()) eotfs.push_back("sdr");
  if (h.hdr()) eotfs.push_back("hdr");
  if (h.pq()) eotfs.push_back("pq");
  if (h.hlg()) eotfs.push_back("hlg");
  return {{"location", h.location},
          {"payload_length", h.payload_length},
          {"eotfs", eotfs},
          {"static_metadata_type1", h.static_metadata_type1()},
          {"max_luminance_cv", optional_cv(h.max_luminance_cv)},
          {"max_luminance_cd_m2", optional_number(h.max_luminance_cd_m2())},
          {"max_frame_avg_luminance_cv", optional_cv(h.max_frame_avg_luminance_cv)},
          {"max_frame_avg_luminance_cd_m2", optional_number(h.max_frame_avg_luminance_cd_m2())},
          {"min_luminance_cv", optional_cv(h.min_luminance_cv)},
          {"min_luminance_cd_m2", optional_number(h.min_luminance_cd_m2())}};
}

json edid_to_json(const EdidInfo& info) {
  json j;
  j["size_bytes"] = info.size_bytes;
  j["edid_version"] = fmt::format("{}.{}", info.version, info.revision);
  j["manufacturer"] = info.manufacturer;
  j["product_code"] = info.product_code;
  j["product_code_hex"] = fmt::format("0x{:04X}", info.product_code);
  j["serial_number"] = info.serial_number;
  j["serial_string"] = info.serial_string ? json(*info.serial_string) : json(nullptr);
  j["name"] = info.name;
  j["made_in"] = made_in(info);
  j["digital"] = info.digital;
  j["bits_per_color"] = info.bits_per_color ? json(info.bits_per_color) : json(nullptr);
  j["interface"] = info.interface.empty() ? json(nullptr) : json(info.interface);
  j["image_size_cm"] = json::array({info.width_cm, info.height_cm});
  j["gamma"] = optional_number(info.gamma);
  j["chromaticity"] = chromaticity_json(info.chromaticity);
  j["chromaticity_raw"] = chromaticity_raw_json(info.chromaticity);
  j["preferred_timing"] = info.preferred_timing() ? timing_to_json(*info.preferred_timing()) : json(nullptr);
  json exts = json::array();
  for (const auto& e : info.extensions)
    exts.push_back({{"block", e.index}, {"tag", fmt::format("0x{:02x}", e.tag)}, {"name", e.name},
                    {"checksum_ok", e.checksum_ok}});
  j["extensions"] = exts;
  j["hdr_static_metadata"] =
      info.hdr_static_metadata ? hdr_static_metadata_to_json(*info.hdr_static_metadata) : json(nullptr);
  j["colorimetry"] = info.colorimetry ? json(colorimetry_names(*info.colorimetry)) : json::array();
  j["colorimetry_raw"] = info.colorimetry ? json::array({info.colorimetry->byte3, info.colorimetry->byte4})
                                          : json(nullptr);
  j["hdr10plus_vsvdb"] = info.hdr10plus_vsvdb;
  j["dolby_vision_vsvdb"] = info.dolby_vision_vsvdb;
  j["hdr_dynamic_metadata_types"] = info.hdr_dynamic_metadata_types;
  if (info.video_capability) {
    const auto& v = *info.video_capability;
    j["video_capability"] = {{"ycc_quantization_selectable", v.ycc_quantization_selectable},
                             {"rgb_quantization_selectable", v.rgb_quantization_selectable},
                             {"pt", v.pt}, {"it", v.it}, {"ce", v.ce}};
  } else {
    j["video_capability"] = nullptr;
  }
  j["displayid"] = displayid_json(info);
  j["displayid_display_parameters"] =
      info.displayid_parameters ? displayid_parameters_json(*info.displayid_parameters) : json(nullptr);
  j["displayid_colorspace_eotf_combinations"] =
      info.displayid_interface ? json(info.displayid_interface->combination_names()) : json::array();
  j["warnings"] = info.warnings;
  return j;
}

}  // namespace hdrd::display

#include "encode/video/hdr10plus.hpp"

#include <fmt/format.h>

#include "encode/video/bitstream.hpp"

namespace hdrd::video {

namespace {

Error bad(const char* field, std::string message) {
  return make_error("hdr10plus.range", std::move(message), std::string("hdr10plus.") + field);
}

constexpr std::uint32_t kMaxLinear = 100000;  // 1.0 of linearized RGB in 0.00001

}  // namespace

Result<void> validate(const Hdr10PlusFrame& m) {
  if (m.targeted_system_display_maximum_luminance > 10000)
    return bad("targeted_system_display_maximum_luminance",
               fmt::format("targeted system display peak {} cd/m2 is above 10000", m.targeted_system_display_maximum_luminance));
  for (int c = 0; c < 3; ++c)
    if (m.maxscl[static_cast<std::size_t>(c)] > kMaxLinear)
      return bad("maxscl", fmt::format("maxscl[{}] = {} is above {}", c, m.maxscl[static_cast<std::size_t>(c)], kMaxLinear));
  if (m.average_maxrgb > kMaxLinear)
    return bad("average_maxrgb", fmt::format("average_maxrgb {} is above {}", m.average_maxrgb, kMaxLinear));
  if (m.distribution.empty() || m.distribution.size() > 15)
    return bad("distribution", fmt::format("{} distribution percentiles (1 to 15 fit the 4-bit count)", m.distribution.size()));
  for (std::size_t i = 0; i < m.distribution.size(); ++i) {
    const auto& p = m.distribution[i];
    if (p.percentage > 100) return bad("distribution", fmt::format("percentage {} is above 100", p.percentage));
    if (p.value > kMaxLinear) return bad("distribution", fmt::format("percentile value {} is above {}", p.value, kMaxLinear));
    if (i > 0 && (p.percentage <= m.distribution[i - 1].percentage || p.value < m.distribution[i - 1].value))
      return bad("distribution", "percentages must increase and their values must not decrease");
  }
  if (m.fraction_bright_pixels > 1000)
    return bad("fraction_bright_pixels", fmt::format("fraction_bright_pixels {} is above 1000", m.fraction_bright_pixels));
  if (m.bezier) {
    const auto& b = *m.bezier;
    if (b.knee_point_x > 4095 || b.knee_point_y > 4095) return bad("knee_point", "knee point coordinates are above 4095");
    if (b.anchors.size() > 9) return bad("bezier_curve_anchors", fmt::format("{} Bezier anchors (HDR10+ allows 9)", b.anchors.size()));
    for (auto a : b.anchors)
      if (a > 1023) return bad("bezier_curve_anchors", fmt::format("Bezier anchor {} is above 1023", a));
    if (m.targeted_system_display_maximum_luminance == 0)
      return bad("targeted_system_display_maximum_luminance", "a Bezier curve needs the display it targets (peak > 0)");
  }
  return {};
}

std::vector<std::uint8_t> hdr10plus_t35(const Hdr10PlusFrame& m) {
  BitWriter w;
  w.put(0xB5, 8);    // itu_t_t35_country_code: United States
  w.put(0x003C, 16);  // terminal_provider_code: SMPTE
  w.put(0x0001, 16);  // terminal_provider_oriented_code: ST 2094-40
  w.put(4, 8);        // application_identifier
  w.put(1, 8);        // application_version
  w.put(1, 2);        // num_windows: the whole picture
  w.put(m.targeted_system_display_maximum_luminance, 27);
  w.put(0, 1);        // targeted_system_display_actual_peak_luminance_flag
  for (auto v : m.maxscl) w.put(v, 17);
  w.put(m.average_maxrgb, 17);
  w.put(m.distribution.size(), 4);
  for (const auto& p : m.distribution) {
    w.put(p.percentage, 7);
    w.put(p.value, 17);
  }
  w.put(m.fraction_bright_pixels, 10);
  w.put(0, 1);  // mastering_display_actual_peak_luminance_flag
  w.put(m.bezier ? 1 : 0, 1);  // tone_mapping_flag
  if (m.bezier) {
    w.put(m.bezier->knee_point_x, 12);
    w.put(m.bezier->knee_point_y, 12);
    w.put(m.bezier->anchors.size(), 4);
    for (auto a : m.bezier->anchors) w.put(a, 10);
  }
  w.put(0, 1);  // color_saturation_mapping_flag
  return w.bytes();
}

nlohmann::json hdr10plus_json_entry(const Hdr10PlusFrame& m, int scene_id, int scene_frame_index,
                                    int sequence_frame_index) {
  nlohmann::json index = nlohmann::json::array(), values = nlohmann::json::array();
  for (const auto& p : m.distribution) {
    index.push_back(p.percentage);
    values.push_back(p.value);
  }
  nlohmann::json e{{"LuminanceParameters",
                    {{"AverageRGB", m.average_maxrgb},
                     {"LuminanceDistributions", {{"DistributionIndex", index}, {"DistributionValues", values}}},
                     {"MaxScl", m.maxscl}}},
                   {"NumberOfWindows", 1},
                   {"TargetedSystemDisplayMaximumLuminance", m.targeted_system_display_maximum_luminance},
                   {"SceneFrameIndex", scene_frame_index},
                   {"SceneId", scene_id},
                   {"SequenceFrameIndex", sequence_frame_index}};
  if (m.bezier)
    e["BezierCurveData"] = {{"Anchors", m.bezier->anchors},
                            {"KneePointX", m.bezier->knee_point_x},
                            {"KneePointY", m.bezier->knee_point_y}};
  return e;
}

}  // namespace hdrd::video

// Metadata measured from a sequence's frames as they are encoded, one frame at a time:
//  - the static set (CTA-861.3): MaxCLL = the largest maxRGB of any pixel of any frame,
//    MaxFALL = the largest frame average of maxRGB (measure_frame_light decodes the codes);
//  - per scene (or per frame), the dynamic sets: HDR10+ (ST 2094-40: maxscl, average
//    maxRGB, the maxRGB distribution at nine percentages, optional Bezier curve) and
//    Dolby Vision level 1 (min / average / max of PQ(maxRGB), 12-bit).
// A scene's values pool its frames: maxima of maxima, the mean of frame means, the
// percentiles of all its pixels. Memory: one 4096-level histogram for the open scene and
// a few numbers per scene (per frame with frame granularity).
// Dynamic metadata is defined for PQ: hdr10 only (HLG and SDR get the static set alone
// where it applies, see has_dynamic_metadata()).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/display_target.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"
#include "encode/video/hdr10plus.hpp"

namespace hdrd::video {

enum class MetadataGranularity { scene, frame };
std::string_view to_string(MetadataGranularity g);
std::optional<MetadataGranularity> parse_granularity(std::string_view s);  // "scene", "frame"

struct SequenceMetadataSettings {
  MetadataGranularity granularity = MetadataGranularity::scene;
  // HDR10+ profile B: a Bezier tone curve for a display of this peak (cd/m2, 100..10000),
  // fitted per scene to BT.2390's EETF from the scene's peak; none: profile A (no curve).
  std::optional<double> hdr10plus_target_nits;
};
Result<void> validate(const SequenceMetadataSettings& s);

// The light of a set of pixels (a frame or a scene). PQ values are signals in [0, 1],
// quantised to 12 bits as FrameLight's histogram is.
struct LightSummary {
  std::array<double, 3> max_channel_nits{};
  double max_nits = 0, mean_nits = 0, min_nits = 0;  // of maxRGB
  std::array<double, kHdr10PlusPercentages.size()> percentile_nits{};
  double min_pq = 0, mean_pq = 0, max_pq = 0;
};

struct DoviL1 {
  std::uint16_t min_pq = 0, avg_pq = 0, max_pq = 0;  // 12-bit PQ codes, min <= avg <= max
};

struct SceneRange {
  int first_frame = 0, last_frame = 0;  // inclusive
};

class SequenceMetadata {
 public:
  SequenceMetadata(const DisplayTarget& target, const MasteringDisplay& mastering,
                   const SequenceMetadataSettings& settings = {});
  SequenceMetadata(SequenceMetadata&&) = default;
  SequenceMetadata& operator=(SequenceMetadata&&) = default;
  SequenceMetadata(const SequenceMetadata&) = delete;  // the open scene's totals are one object's
  SequenceMetadata& operator=(const SequenceMetadata&) = delete;

  // The next frame in display order; scene_start opens a new scene (the first frame always
  // does). The frame's mode must be the sequence's. hdr10 frames are measured
  // (measure_frame_light); others contribute their EncodedFrame::content_light.
  Result<void> add(const EncodedFrame& frame, bool scene_start);
  Result<void> add(const FrameLight& light, bool scene_start);  // when the caller measured it
  // What add(frame) adds: the frame's measured light (hdr10), else its content light alone.
  FrameLight light_of(const EncodedFrame& frame) const;
  // Closes the last scene; afterwards only the accessors below.
  void finish();

  int frame_count() const { return frames_; }
  const std::vector<SceneRange>& scenes() const { return scenes_; }
  int scene_of(int frame) const;
  bool has_dynamic_metadata() const { return target_.mode == Mode::hdr10; }
  const MasteringDisplay& mastering() const { return mastering_; }
  // Sequence MaxCLL / MaxFALL in cd/m2 (as measured; carriers round up).
  ContentLightLevel content_light() const { return content_light_; }

  // After finish(), for frame i in display order: the summary its dynamic metadata is
  // made of (its scene's, or its own with frame granularity), and that metadata.
  const LightSummary& light(int frame) const;
  Hdr10PlusFrame hdr10plus(int frame) const;
  DoviL1 dovi_l1(int frame) const;

  // OUTBASE.hdr10plus.json: the layout x265's --dhdr10-info reads (one SceneInfo entry per
  // frame). OUTBASE.dovi.json: dovi_tool generate's config (profile 8.1, level 6 from the
  // mastering display and content light, one shot per scene with its level 1, per-frame
  // level 1 as frame_edits with frame granularity).
  nlohmann::json hdr10plus_json() const;
  nlohmann::json dovi_json() const;

 private:
  struct Pool;  // running totals of the open scene
  void close_scene();

  DisplayTarget target_;
  MasteringDisplay mastering_;
  SequenceMetadataSettings settings_;
  int frames_ = 0;
  bool finished_ = false;
  ContentLightLevel content_light_;
  std::vector<SceneRange> scenes_;
  std::vector<LightSummary> scene_light_, frame_light_;
  std::vector<std::optional<Hdr10PlusBezier>> scene_curve_;
  std::shared_ptr<Pool> pool_;
};

// The summary of one or more frames' light (pooled); exposed for tests.
LightSummary summarise(std::span<const FrameLight* const> frames);
Hdr10PlusFrame hdr10plus_from(const LightSummary& light);
DoviL1 dovi_l1_from(const LightSummary& light);
// HDR10+ profile B curve (ST 2094-40 basis tone mapping): y = (ky / kx) x below the knee,
// y = ky + (1 - ky) B((x - kx) / (1 - kx)) above it, B the Bezier curve through 0, the
// anchors and 1; x normalised to the source peak, y to the target display's. Fitted to the
// BT.2390 EETF (least squares for the anchors, the knee searched for the smallest largest
// error in PQ); empty when the source fits the target (no tone mapping needed).
std::optional<Hdr10PlusBezier> fit_bezier(double source_peak_nits, double target_peak_nits);
double bezier_curve(const Hdr10PlusBezier& curve, double x);

}  // namespace hdrd::video

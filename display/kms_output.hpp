// Scanning out one encoded frame on a connector with an atomic commit (TEST_ONLY first,
// then the real commit): connector -> CRTC -> primary plane, a dumb buffer at the mode's
// size, HDR_OUTPUT_METADATA + Colorspace + max bpc for HDR signals.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "display/hdr_metadata.hpp"
#include "display/kms.hpp"
#include "display/scanout.hpp"
#include "encode/frame.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

struct PresentOptions {
  std::string connector;              // "HDMI-A-1"; empty = the first connected connector
                                      // (for HDR frames: the first one that can signal HDR)
  bool test_only = false;             // stop after the TEST_ONLY commit
  ScrgbPolicy scrgb = ScrgbPolicy::convert;
  // HDR signals need HDR_OUTPUT_METADATA and Colorspace on the connector, or the display
  // shows PQ/HLG codes as SDR. Off only for tests on drivers without them (vkms).
  bool require_hdr_properties = true;
};

struct PresentResult {
  std::string device;
  std::string connector;
  kms::ModeInfo mode;
  std::uint32_t crtc_id = 0, plane_id = 0, fb_id = 0;
  std::uint32_t fourcc = 0;
  Mode signal = Mode::sdr;            // what was sent (scRGB becomes hdr10)
  std::string colorspace;             // "BT2020_RGB", "Default", or "" when the property is absent
  std::optional<HdrOutputMetadata> hdr_metadata;
  std::optional<std::uint64_t> max_bpc;
  bool committed = false;             // false after a TEST_ONLY-only run
  std::vector<std::string> notes;
};

// The connector to use: by name, or the first connected one (with `prefer_hdr`, the first
// connected one that has HDR_OUTPUT_METADATA and Colorspace, if any). Errors say clearly
// when no display is attached.
Result<kms::Connector> pick_connector(kms::KmsDevice& device, const std::string& name, bool prefer_hdr = false);

// Where frames go, and the pieces of the atomic request: shared by KmsOutput (one frame)
// and SequencePresenter (display/sequence_presenter.hpp: frames at the refresh rate).
struct OutputRoute {
  kms::Connector connector;
  kms::Properties connector_props;
  std::uint32_t crtc_id = 0;
  kms::Properties crtc_props;
  std::uint32_t plane_id = 0;
  kms::Properties plane_props;
  kms::ModeInfo mode;  // the frame's own size if the connector has it, else the preferred mode
};

// Connector, CRTC, primary plane taking the frame's fourcc, and mode for a scan-out-ready
// frame (prepare_for_scanout's output).
Result<OutputRoute> plan_route(kms::KmsDevice& device, const EncodedFrame& frame, const PresentOptions& options);

// Connector -> CRTC, MODE_ID = `mode_blob`, ACTIVE = 1 and the plane's rectangles (the
// whole mode, 16.16 source coordinates).
void add_modeset(const OutputRoute& route, std::uint32_t mode_blob, kms::AtomicRequest& request);
// The plane's FB_ID alone: what a page flip changes.
void add_flip(const OutputRoute& route, std::uint32_t fb_id, kms::AtomicRequest& request);
// Plane, CRTC and connector off (FB_ID, CRTC_ID = 0, ACTIVE = 0, MODE_ID = 0) and
// HDR_OUTPUT_METADATA cleared: a modeset that leaves the display dark and unsignalled.
void add_disable(const OutputRoute& route, kms::AtomicRequest& request);

// HDR_OUTPUT_METADATA (a blob of the frame's mode and mastering display with `light`,
// whose id is appended to `blobs`; cleared for SDR), Colorspace and max bpc (REFERENCE.md §6).
Result<void> add_signalling(kms::KmsDevice& device, const EncodedFrame& frame, const ContentLightLevel& light,
                            const OutputRoute& route, const PresentOptions& options, kms::AtomicRequest& request,
                            PresentResult& out, std::vector<std::uint32_t>& blobs);

// Black in the buffer's format: zero, except FP16 alpha = 1.0 so the plane stays opaque.
void fill_black(std::span<std::uint8_t> buffer, std::uint32_t fourcc);
// The frame's rows top-left into a mapped dumb buffer (cropped to it); the rest is left
// as it is (black after fill_black).
void copy_frame(const EncodedFrame& frame, const kms::DumbBuffer& buffer, std::span<std::uint8_t> mapped);
// "frame WxH shown top-left in mode ..." when the frame is not the mode's size.
std::optional<std::string> fit_note(const EncodedFrame& frame, const kms::ModeInfo& mode);

// Owns what a shown frame needs (framebuffer, dumb buffer, blobs) until destroyed or the
// next show(); the kernel turns the plane off when the device is closed.
class KmsOutput {
 public:
  explicit KmsOutput(kms::KmsDevice& device) : device_(device) {}
  ~KmsOutput();
  KmsOutput(const KmsOutput&) = delete;
  KmsOutput& operator=(const KmsOutput&) = delete;

  Result<PresentResult> show(const EncodedFrame& frame, const PresentOptions& options = {});

 private:
  void release();
  Result<void> upload(const EncodedFrame& frame, PresentResult& out);
  kms::KmsDevice& device_;
  std::optional<kms::DumbBuffer> dumb_;
  std::uint32_t fb_ = 0;
  std::vector<std::uint32_t> blobs_;
};

}  // namespace hdrd::display

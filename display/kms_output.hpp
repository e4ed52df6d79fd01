// Scanning out one encoded frame on a connector with an atomic commit (TEST_ONLY first,
// then the real commit): connector -> CRTC -> primary plane, a dumb buffer at the mode's
// size, HDR_OUTPUT_METADATA + Colorspace + max bpc for HDR signals.
#pragma once

#include <optional>
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
  Result<void> add_signalling(const EncodedFrame& frame, const kms::Connector& connector,
                              const kms::Properties& connector_props, const PresentOptions& options,
                              kms::AtomicRequest& request, PresentResult& out);
  kms::KmsDevice& device_;
  std::optional<kms::DumbBuffer> dumb_;
  std::uint32_t fb_ = 0;
  std::vector<std::uint32_t> blobs_;
};

}  // namespace hdrd::display

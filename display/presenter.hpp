// Showing frames on the machine's real displays: finds a DRM device with a connected
// display, keeps it open and the last frame on screen until the next show() or until the
// presenter is destroyed. `hdrd present` and the daemon's POST /v1/present use this.
#pragma once

#include <memory>
#include <string>

#include "display/drm_device.hpp"
#include "display/kms_output.hpp"
#include "display/sequence_presenter.hpp"

namespace hdrd::display {

class Presenter {
 public:
  // `device` pins one card node; empty tries every /dev/dri/card* in turn. Errors:
  // kms.no_display ("no display attached: ...") when there is no device or no connected
  // connector, otherwise what the device or the commit reported.
  Result<PresentResult> show(const EncodedFrame& frame, const PresentOptions& options, const std::string& device = "");
  // Turns the output off by closing the device (the kernel disables the plane).
  void close();

 private:
  std::unique_ptr<DrmDevice> device_;
  std::unique_ptr<KmsOutput> output_;
};

// A SequencePresenter on the first DRM device (or `device`) with a display attached to
// options.present.connector (or any connected one). The library entry point for live
// output of sequences: `hdrd present` of dumps and `hdrd render --frames N --present`
// push frames into it one at a time. Errors as Presenter::show.
Result<std::unique_ptr<SequencePresenter>> open_sequence_presenter(const SequenceOptions& options,
                                                                   const std::string& device = "");

}  // namespace hdrd::display

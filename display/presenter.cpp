#include "display/presenter.hpp"

#include <optional>

namespace hdrd::display {

void Presenter::close() {
  output_.reset();  // releases the framebuffer and blobs while the fd is still open
  device_.reset();
}

Result<PresentResult> Presenter::show(const EncodedFrame& frame, const PresentOptions& options,
                                      const std::string& device) {
  // Keep using the device that showed the last frame, unless another one is asked for.
  if (device_ && output_ && (device.empty() || device == device_->path())) {
    auto r = output_->show(frame, options);
    if (r || (r.error().code != "kms.no_display" && r.error().code != "kms.no_connector")) return r;
    close();  // the display went away: look again below
  }
  close();
  const std::vector<std::string> paths = device.empty() ? drm_card_paths() : std::vector<std::string>{device};
  if (paths.empty()) return make_error("kms.no_display", "no display attached: this machine has no DRM devices (headless)");
  std::optional<Error> last;
  for (const auto& path : paths) {
    auto dev = DrmDevice::open(path);
    if (!dev) return dev.error();
    auto out = std::make_unique<KmsOutput>(**dev);
    auto r = out->show(frame, options);
    if (r) {
      device_ = std::move(*dev);
      output_ = std::move(out);
      return r;
    }
    if (r.error().code != "kms.no_display" && r.error().code != "kms.no_connector") return r.error();
    last = r.error();
  }
  return *last;
}

Result<std::unique_ptr<SequencePresenter>> open_sequence_presenter(const SequenceOptions& options,
                                                                   const std::string& device) {
  const std::vector<std::string> paths = device.empty() ? drm_card_paths() : std::vector<std::string>{device};
  if (paths.empty()) return make_error("kms.no_display", "no display attached: this machine has no DRM devices (headless)");
  std::optional<Error> last;
  for (const auto& path : paths) {
    auto dev = DrmDevice::open(path);
    if (!dev) return dev.error();
    if (auto c = pick_connector(**dev, options.present.connector); !c) {
      if (c.error().code != "kms.no_display" && c.error().code != "kms.no_connector") return c.error();
      last = c.error();
      continue;
    }
    std::unique_ptr<kms::KmsDevice> owned = std::move(*dev);
    return std::make_unique<SequencePresenter>(std::move(owned), options);
  }
  return *last;
}

}  // namespace hdrd::display

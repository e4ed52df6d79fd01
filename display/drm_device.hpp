// The libdrm implementation of kms::KmsDevice, and DRM device discovery.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "display/kms.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

// Primary nodes (/dev/dri/cardN) of every DRM device. Empty when there are none:
// drmGetDevices2 returns <= 0 (-ENOENT on a headless VM without /dev/dri).
std::vector<std::string> drm_card_paths();

class DrmDevice final : public kms::KmsDevice {
 public:
  // Opens a card node and enables universal planes and atomic modesetting (if the driver
  // has it; enumeration works without). `writeback` also exposes writeback connectors.
  static Result<std::unique_ptr<DrmDevice>> open(const std::string& path, bool writeback = false);
  ~DrmDevice() override;
  DrmDevice(const DrmDevice&) = delete;
  DrmDevice& operator=(const DrmDevice&) = delete;

  bool atomic() const { return atomic_; }
  int fd() const { return fd_; }

  std::string path() const override { return path_; }
  std::string driver() const override { return driver_; }
  Result<kms::Resources> resources() override;
  Result<kms::Connector> connector(std::uint32_t id) override;
  Result<kms::Plane> plane(std::uint32_t id) override;
  Result<kms::Properties> properties(std::uint32_t object, std::uint32_t object_type) override;
  Result<std::vector<std::uint8_t>> blob(std::uint32_t blob_id) override;
  Result<std::uint32_t> create_blob(std::span<const std::uint8_t> bytes) override;
  Result<std::uint32_t> create_mode_blob(const kms::ModeInfo& mode) override;
  void destroy_blob(std::uint32_t blob_id) override;
  Result<kms::DumbBuffer> create_dumb(std::uint32_t width, std::uint32_t height, std::uint32_t bpp) override;
  Result<std::span<std::uint8_t>> map_dumb(const kms::DumbBuffer& buffer) override;
  void destroy_dumb(const kms::DumbBuffer& buffer) override;
  Result<std::uint32_t> add_fb2(std::uint32_t width, std::uint32_t height, std::uint32_t fourcc, std::uint32_t handle,
                                std::uint32_t pitch) override;
  void remove_fb(std::uint32_t fb_id) override;
  Result<void> atomic_commit(const kms::AtomicRequest& request, std::uint32_t flags) override;
  Result<void> atomic_commit_with_event(const kms::AtomicRequest& request, std::uint32_t flags,
                                        std::uint64_t user_data) override;
  Result<std::vector<kms::FlipEvent>> read_flip_events(std::chrono::milliseconds timeout) override;

 private:
  DrmDevice(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  Result<void> commit(const kms::AtomicRequest& request, std::uint32_t flags, void* user_data);
  int fd_ = -1;
  std::string path_;
  std::string driver_;
  bool atomic_ = false;
  std::map<std::uint32_t, std::pair<void*, std::size_t>> mappings_;  // dumb handle -> mmap
};

}  // namespace hdrd::display

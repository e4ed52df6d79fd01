// The render workers' resource: one shading::Renderer (and so one GL context) per worker
// thread, created on that thread. When no GL backend works, the factory says so and
// POST /v1/render answers 503 renderer.unavailable.
#pragma once

#include <memory>
#include <string>

#include "daemon/jobs/scheduler.hpp"
#include "shading/renderer.hpp"

namespace hdrd::daemon {

class RendererResource final : public RenderResource {
 public:
  RendererResource(std::unique_ptr<shading::Renderer> r, shading::Backend backend)
      : renderer(std::move(r)), backend_(backend) {}
  nlohmann::json info() const override;
  // Frees the frame's targets; after a job of kRecreateAfterBytes or more, replaces the
  // renderer (its GL context) instead: llvmpipe keeps a large MSAA frame's storage
  // referenced until the next frame is drawn, whatever is deleted (measured: 160 MiB
  // after a 1080p 4x MSAA frame), and a new context costs tens of milliseconds.
  void release_large_buffers(std::uint64_t job_memory_bytes) override;
  std::unique_ptr<shading::Renderer> renderer;

 private:
  shading::Backend backend_;
};

// Makes a renderer with the configured backend ("auto", "egl", "osmesa", ...).
RenderResourceFactory renderer_factory(const std::string& backend_name);

}  // namespace hdrd::daemon

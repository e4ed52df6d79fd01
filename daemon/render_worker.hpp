// The render workers' resource: one shading::Renderer (and so one GL context) per worker
// thread, created on that thread. When the build has no renderer, the factory says so
// and POST /v1/render answers 503 renderer.unavailable.
#pragma once

#include <memory>
#include <string>

#include "daemon/scheduler.hpp"

#if defined(HDRD_SHADING_AVAILABLE) && __has_include("shading/renderer.hpp")
#include "shading/renderer.hpp"
#define HDRD_HAVE_RENDERER 1
#endif

namespace hdrd::daemon {

#ifdef HDRD_HAVE_RENDERER
class RendererResource final : public RenderResource {
 public:
  explicit RendererResource(std::unique_ptr<shading::Renderer> r) : renderer(std::move(r)) {}
  nlohmann::json info() const override;
  void release_large_buffers() override { renderer->release_frame_targets(); }
  std::unique_ptr<shading::Renderer> renderer;
};
#endif

// Makes a renderer with the configured backend ("auto", "egl", "osmesa", ...).
RenderResourceFactory renderer_factory(const std::string& backend_name);

}  // namespace hdrd::daemon

// The render workers' resource: one shading::Renderer (and so one GL context) per worker
// thread, created on that thread. When no GL backend works, the factory says so and
// POST /v1/render answers 503 renderer.unavailable.
#pragma once

#include <memory>
#include <string>

#include "daemon/scheduler.hpp"
#include "shading/renderer.hpp"

namespace hdrd::daemon {

class RendererResource final : public RenderResource {
 public:
  explicit RendererResource(std::unique_ptr<shading::Renderer> r) : renderer(std::move(r)) {}
  nlohmann::json info() const override;
  std::unique_ptr<shading::Renderer> renderer;
};

// Makes a renderer with the configured backend ("auto", "egl", "osmesa", ...).
RenderResourceFactory renderer_factory(const std::string& backend_name);

}  // namespace hdrd::daemon

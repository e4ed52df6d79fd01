#include "daemon/render_worker.hpp"

#include <spdlog/spdlog.h>

namespace hdrd::daemon {

nlohmann::json RendererResource::info() const {
  const auto& c = renderer->context();
  return {{"backend", renderer->backend_name()}, {"gl_renderer", c.gl_renderer()}, {"gl_version", c.gl_version()}};
}

RenderResourceFactory renderer_factory(const std::string& backend_name) {
  return [backend_name](int index) -> Result<std::unique_ptr<RenderResource>> {
    const auto backend = shading::parse_backend(backend_name);
    if (!backend) return make_error("config.invalid", "unknown renderer backend '" + backend_name + "'");
    auto r = shading::Renderer::create(*backend);
    if (!r) return r.error();
    auto res = std::make_unique<RendererResource>(std::move(*r));
    spdlog::info("render worker {}: {} ({})", index, res->renderer->backend_name(),
                 res->renderer->context().gl_renderer());
    return std::unique_ptr<RenderResource>(std::move(res));
  };
}

}  // namespace hdrd::daemon

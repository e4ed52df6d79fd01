#include "daemon/jobs/render_worker.hpp"

#include <chrono>

#include <spdlog/spdlog.h>

namespace hdrd::daemon {

nlohmann::json RendererResource::info() const {
  const auto& c = renderer->context();
  return {{"backend", renderer->backend_name()}, {"gl_renderer", c.gl_renderer()}, {"gl_version", c.gl_version()}};
}

namespace {
constexpr std::uint64_t kRecreateAfterBytes = std::uint64_t(256) << 20;
}

void RendererResource::release_large_buffers(std::uint64_t job_memory_bytes) {
  if (job_memory_bytes < kRecreateAfterBytes) return renderer->release_frame_targets();
  const auto t0 = std::chrono::steady_clock::now();
  auto fresh = shading::Renderer::create(backend_);
  if (!fresh) {  // keep the one that works
    spdlog::warn("render worker: could not replace the renderer after a large frame: {}", fresh.error().message);
    return renderer->release_frame_targets();
  }
  renderer = std::move(*fresh);  // the old context and everything it held go here
  spdlog::debug("render worker: renderer replaced after a {} MiB job in {:.1f} ms", job_memory_bytes >> 20,
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

RenderResourceFactory renderer_factory(const std::string& backend_name) {
  return [backend_name](int index) -> Result<std::unique_ptr<RenderResource>> {
    const auto backend = shading::parse_backend(backend_name);
    if (!backend) return make_error("config.invalid", "unknown renderer backend '" + backend_name + "'");
    auto r = shading::Renderer::create(*backend);
    if (!r) return r.error();
    auto res = std::make_unique<RendererResource>(std::move(*r), *backend);
    spdlog::info("render worker {}: {} ({})", index, res->renderer->backend_name(),
                 res->renderer->context().gl_renderer());
    return std::unique_ptr<RenderResource>(std::move(res));
  };
}

}  // namespace hdrd::daemon

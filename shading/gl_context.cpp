#include "shading/gl_context.hpp"

#include <cctype>

#include <fmt/format.h>

namespace hdrd::shading {

RendererKind renderer_kind(std::string_view gl_renderer) {
  std::string lower(gl_renderer);
  for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (std::string_view software : {"llvmpipe", "softpipe", "swrast", "swiftshader", "software rasterizer"})
    if (lower.find(software) != std::string::npos) return RendererKind::software;
  return RendererKind::hardware;
}

std::string_view to_string(RendererKind k) { return k == RendererKind::software ? "software" : "hardware"; }

std::string_view to_string(Backend b) {
  switch (b) {
    case Backend::automatic: return "auto";
    case Backend::egl: return "egl";
    case Backend::egl_device: return "egl-device";
    case Backend::egl_surfaceless: return "egl-surfaceless";
    case Backend::osmesa: return "osmesa";
  }
  return "auto";
}

std::optional<Backend> parse_backend(std::string_view s) {
  if (s == "auto") return Backend::automatic;
  if (s == "egl") return Backend::egl;
  if (s == "egl-device") return Backend::egl_device;
  if (s == "egl-surfaceless") return Backend::egl_surfaceless;
  if (s == "osmesa") return Backend::osmesa;
  return std::nullopt;
}

Result<void> GlContext::finish_setup(GlApi::GetProc get_proc, bool gles) {
  const std::string missing = gl_.load(get_proc);
  if (!missing.empty())
    return make_error("gl.entry_point", fmt::format("GL entry point {} is missing", missing));
  gl_.gles = gles;
  auto str = [&](GLenum e) {
    const auto* s = reinterpret_cast<const char*>(gl_.GetString(e));
    return std::string(s ? s : "");
  };
  renderer_ = str(GL_RENDERER);
  version_ = str(GL_VERSION);
  GLint major = 0, minor = 0;
  gl_.GetIntegerv(GL_MAJOR_VERSION, &major);
  gl_.GetIntegerv(GL_MINOR_VERSION, &minor);
  const int have = major * 10 + minor, need = gles ? 32 : 45;
  if (have < need)
    return make_error("gl.version", fmt::format("context reports GL {} (need {} {}.{})", version_,
                                                gles ? "GLES" : "GL", need / 10, need % 10));
  return {};
}

Result<std::unique_ptr<GlContext>> GlContext::create(const ContextOptions& options) {
  struct Attempt {
    const char* name;
    Result<std::unique_ptr<GlContext>> (*make)(GlFlavor);
  };
  static constexpr Attempt kDevice{"egl-device", [](GlFlavor f) { return create_egl_context(true, f); }};
  static constexpr Attempt kSurfaceless{"egl-surfaceless", [](GlFlavor f) { return create_egl_context(false, f); }};
  static constexpr Attempt kOsmesa{"osmesa", [](GlFlavor f) { return create_osmesa_context(f); }};
  std::vector<Attempt> order;
  switch (options.backend) {
    case Backend::automatic: order = {kDevice, kSurfaceless, kOsmesa}; break;
    case Backend::egl: order = {kDevice, kSurfaceless}; break;
    case Backend::egl_device: order = {kDevice}; break;
    case Backend::egl_surfaceless: order = {kSurfaceless}; break;
    case Backend::osmesa: order = {kOsmesa}; break;
  }

  std::vector<std::string> failures;
  for (const Attempt& a : order) {
    auto ctx = a.make(options.flavor);
    if (ctx.ok()) {
      (*ctx)->attempts_ = failures;
      return std::move(ctx).value();
    }
    failures.push_back(fmt::format("{}: {}", a.name, ctx.error().message));
  }
  std::string all;
  for (const auto& f : failures) all += (all.empty() ? "" : "; ") + f;
  return make_error("gl.no_context",
                    fmt::format("no GL context for backend '{}' ({})", to_string(options.backend), all),
                    "backend");
}

}  // namespace hdrd::shading

// Headless GL contexts: EGL (device platform, then Mesa surfaceless) with OSMesa as
// the fallback (platform-debian12.md §1-2). Desktop GL 4.5 core is preferred, GLES 3.2
// accepted. A context is used from one thread at a time: make_current() binds it to
// the calling thread, release() unbinds it so another thread may take it.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/result.hpp"
#include "shading/gl_api.hpp"

namespace hdrd::shading {

// egl: device platform, then surfaceless. egl-device / egl-surfaceless pin one platform.
enum class Backend { automatic, egl, egl_device, egl_surfaceless, osmesa };
std::string_view to_string(Backend b);  // "auto", "egl", "egl-device", "egl-surfaceless", "osmesa"
std::optional<Backend> parse_backend(std::string_view s);

enum class GlFlavor { automatic, desktop, gles };

// What rasterises: a GPU, or the CPU through a software rasteriser (Mesa's llvmpipe, softpipe
// and swrast, SwiftShader), told by GL_RENDERER. The encoder rule differs (job::choose_encoder).
enum class RendererKind { hardware, software };
RendererKind renderer_kind(std::string_view gl_renderer);
std::string_view to_string(RendererKind k);  // "hardware", "software"  // automatic: desktop 4.5 core, else GLES 3.2

struct ContextOptions {
  Backend backend = Backend::automatic;
  GlFlavor flavor = GlFlavor::automatic;
};

class GlContext {
 public:
  // Tries, in order: EGL device platform (a hardware device, one without
  // EGL_MESA_device_software, when present), EGL Mesa surfaceless, OSMesa; each
  // with desktop GL 4.5 core then GLES 3.2. The error lists every attempt.
  static Result<std::unique_ptr<GlContext>> create(const ContextOptions& options = {});
  virtual ~GlContext() = default;
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  virtual Result<void> make_current() = 0;
  virtual void release() = 0;

  const GlApi& gl() const { return gl_; }
  bool gles() const { return gl_.gles; }
  const std::string& backend_name() const { return backend_name_; }  // "egl-device", "egl-surfaceless", "osmesa"
  const std::string& gl_renderer() const { return renderer_; }
  const std::string& gl_version() const { return version_; }
  const std::string& device() const { return device_; }  // EGL device extensions / "osmesa"
  // Attempts that failed before this context was made (for diagnostics).
  const std::vector<std::string>& attempts() const { return attempts_; }

 protected:
  GlContext() = default;
  // Called with the context current: loads the function table and reads the strings.
  Result<void> finish_setup(GlApi::GetProc get_proc, bool gles);

  GlApi gl_;
  std::string backend_name_, renderer_, version_, device_;
  std::vector<std::string> attempts_;
};

// Makes the context current for a scope and releases it afterwards.
class CurrentContext {
 public:
  explicit CurrentContext(GlContext& c) : c_(c), ok_(c.make_current()) {}
  ~CurrentContext() { if (ok_) c_.release(); }
  CurrentContext(const CurrentContext&) = delete;
  CurrentContext& operator=(const CurrentContext&) = delete;
  const Result<void>& status() const { return ok_; }

 private:
  GlContext& c_;
  Result<void> ok_;
};

// Implementation hooks (gl_context_egl.cpp, gl_context_osmesa.cpp).
Result<std::unique_ptr<GlContext>> create_egl_context(bool device_platform, GlFlavor flavor);
Result<std::unique_ptr<GlContext>> create_osmesa_context(GlFlavor flavor);

}  // namespace hdrd::shading

// EGL contexts without a window system: EGL_EXT_platform_device or
// EGL_MESA_platform_surfaceless, no config, no surface (EGL_KHR_no_config_context,
// EGL_KHR_surfaceless_context). eglGetDisplay(EGL_DEFAULT_DISPLAY) is never used: it
// defaults to x11 and fails headless (platform-debian12.md §1).
#define EGL_NO_X11 1  // keep Xlib macros (None, Bool, Status) out
#define MESA_EGL_NO_X11_HEADERS 1
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "shading/gl_context.hpp"

namespace hdrd::shading {
namespace {

bool has_extension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

std::string egl_error_name(EGLint e) {
  switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    default: return fmt::format("EGL error 0x{:x}", e);
  }
}

void* egl_get_proc(const char* name) { return reinterpret_cast<void*>(eglGetProcAddress(name)); }

struct DisplayChoice {
  EGLDisplay display = EGL_NO_DISPLAY;
  std::string description;
};

// The device platform: a hardware device (no EGL_MESA_device_software) first.
Result<DisplayChoice> device_display() {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_EXT_device_enumeration") || !has_extension(client, "EGL_EXT_platform_device"))
    return make_error("gl.egl", "EGL_EXT_device_enumeration / EGL_EXT_platform_device not offered");
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(egl_get_proc("eglQueryDevicesEXT"));
  auto query_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(egl_get_proc("eglQueryDeviceStringEXT"));
  if (!query_devices || !query_string) return make_error("gl.egl", "eglQueryDevicesEXT not found");
  EGLDeviceEXT devices[16];
  EGLint count = 0;
  if (!query_devices(16, devices, &count) || count <= 0) return make_error("gl.egl", "no EGL devices");
  int pick = -1;
  for (int i = 0; i < count && pick < 0; ++i)
    if (!has_extension(query_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software")) pick = i;
  if (pick < 0) pick = 0;  // only software devices (llvmpipe)
  const char* ext = query_string(devices[pick], EGL_EXTENSIONS);
  DisplayChoice c;
  c.description = fmt::format("EGL device {} of {} ({})", pick, count, ext ? ext : "");
  c.display = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[pick], nullptr);
  if (c.display == EGL_NO_DISPLAY) return make_error("gl.egl", "eglGetPlatformDisplay(device) failed");
  return c;
}

Result<DisplayChoice> surfaceless_display() {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_MESA_platform_surfaceless"))
    return make_error("gl.egl", "EGL_MESA_platform_surfaceless not offered");
  DisplayChoice c;
  c.description = "EGL Mesa surfaceless";
  c.display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (c.display == EGL_NO_DISPLAY) return make_error("gl.egl", "eglGetPlatformDisplay(surfaceless) failed");
  return c;
}

class EglContext final : public GlContext {
 public:
  EglContext(EGLDisplay d, EGLContext c, std::string name, std::string device) : display_(d), context_(c) {
    backend_name_ = std::move(name);
    device_ = std::move(device);
  }
  // The display stays initialised for the life of the process: other contexts
  // (one per daemon worker) share it, and eglTerminate would destroy theirs.
  ~EglContext() override { eglDestroyContext(display_, context_); }

  Result<void> make_current() override {
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
      return make_error("gl.current", "eglMakeCurrent failed: " + egl_error_name(eglGetError()));
    return {};
  }
  void release() override { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT); }
  Result<void> setup(bool gles) {
    if (auto r = make_current(); !r) return r;
    auto r = finish_setup(&egl_get_proc, gles);
    release();
    return r;
  }

 private:
  EGLDisplay display_;
  EGLContext context_;
};

EGLContext make_egl_context(EGLDisplay d, bool gles) {
  if (!eglBindAPI(gles ? EGL_OPENGL_ES_API : EGL_OPENGL_API)) return EGL_NO_CONTEXT;
  const EGLint desktop[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                            EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  const EGLint es[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 2, EGL_NONE};
  return eglCreateContext(d, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, gles ? es : desktop);
}

std::mutex& init_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

Result<std::unique_ptr<GlContext>> create_egl_context(bool device_platform, GlFlavor flavor) {
  std::lock_guard lock(init_mutex());
  auto choice = device_platform ? device_display() : surfaceless_display();
  if (!choice) return choice.error();
  EGLint major = 0, minor = 0;
  if (!eglInitialize(choice->display, &major, &minor))
    return make_error("gl.egl", "eglInitialize failed: " + egl_error_name(eglGetError()));
  const char* ext = eglQueryString(choice->display, EGL_EXTENSIONS);
  if (!has_extension(ext, "EGL_KHR_surfaceless_context") || !has_extension(ext, "EGL_KHR_no_config_context"))
    return make_error("gl.egl", "display lacks EGL_KHR_surfaceless_context / EGL_KHR_no_config_context");

  std::string why;
  for (bool gles : {false, true}) {
    if ((flavor == GlFlavor::desktop && gles) || (flavor == GlFlavor::gles && !gles)) continue;
    EGLContext c = make_egl_context(choice->display, gles);
    if (c == EGL_NO_CONTEXT) {
      why += fmt::format("{}{} context: {}", why.empty() ? "" : ", ", gles ? "GLES 3.2" : "GL 4.5 core",
                         egl_error_name(eglGetError()));
      continue;
    }
    auto ctx = std::make_unique<EglContext>(choice->display, c, device_platform ? "egl-device" : "egl-surfaceless",
                                            choice->description);
    if (auto r = ctx->setup(gles); !r) {
      why += fmt::format("{}{}", why.empty() ? "" : ", ", r.error().message);
      continue;
    }
    return std::unique_ptr<GlContext>(std::move(ctx));
  }
  return make_error("gl.egl", why.empty() ? "no context flavour allowed" : why);
}

}  // namespace hdrd::shading

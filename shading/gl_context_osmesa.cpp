// OSMesa fallback, loaded with dlopen only when it is needed. libOSMesa exports all
// 1,292 `gl*` symbols, as glvnd's libraries do; linking it would make direct GL calls
// bind by link order (platform-debian12.md §2). RTLD_LOCAL keeps its symbols out of
// the global namespace, and every GL call goes through OSMesaGetProcAddress.
#include <dlfcn.h>

#include <mutex>
#include <vector>

#include <fmt/format.h>

#include "shading/gl_context.hpp"

namespace hdrd::shading {
namespace {

// The few declarations of <GL/osmesa.h> we need (that header pulls in <GL/gl.h>, whose
// prototypes are exactly what we avoid).
struct osmesa_context;
using OSMesaContext = osmesa_context*;
constexpr int kOsmesaFormat = 0x22, kOsmesaProfile = 0x33, kOsmesaCoreProfile = 0x34;
constexpr int kOsmesaMajor = 0x36, kOsmesaMinor = 0x37, kOsmesaRgba = 0x1908;
using CreateContextAttribsFn = OSMesaContext (*)(const int*, OSMesaContext);
using DestroyContextFn = void (*)(OSMesaContext);
using MakeCurrentFn = unsigned char (*)(OSMesaContext, void*, unsigned, int, int);
using GetProcAddressFn = void* (*)(const char*);

struct OsmesaLib {
  void* handle = nullptr;
  CreateContextAttribsFn create = nullptr;
  DestroyContextFn destroy = nullptr;
  MakeCurrentFn make_current = nullptr;
  GetProcAddressFn get_proc = nullptr;
  std::string error;
};

const OsmesaLib& osmesa() {
  static const OsmesaLib lib = [] {
    OsmesaLib l;
    for (const char* name : {"libOSMesa.so.8", "libOSMesa.so"}) {
      l.handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
      if (l.handle) break;
    }
    if (!l.handle) {
      const char* e = dlerror();
      l.error = fmt::format("cannot load libOSMesa.so.8 ({})", e ? e : "unknown");
      return l;
    }
    l.create = reinterpret_cast<CreateContextAttribsFn>(dlsym(l.handle, "OSMesaCreateContextAttribs"));
    l.destroy = reinterpret_cast<DestroyContextFn>(dlsym(l.handle, "OSMesaDestroyContext"));
    l.make_current = reinterpret_cast<MakeCurrentFn>(dlsym(l.handle, "OSMesaMakeCurrent"));
    l.get_proc = reinterpret_cast<GetProcAddressFn>(dlsym(l.handle, "OSMesaGetProcAddress"));
    if (!l.create || !l.destroy || !l.make_current || !l.get_proc) l.error = "libOSMesa lacks OSMesaCreateContextAttribs";
    return l;
  }();
  return lib;
}

void* osmesa_get_proc(const char* name) { return osmesa().get_proc(name); }

class OsmesaContext final : public GlContext {
 public:
  explicit OsmesaContext(OSMesaContext c) : ctx_(c) {
    backend_name_ = "osmesa";
    device_ = "OSMesa (libOSMesa.so.8)";
  }
  ~OsmesaContext() override { osmesa().destroy(ctx_); }

  // OSMesa needs a client buffer to be current; hdrd renders into FBOs, so 1x1 will do.
  Result<void> make_current() override {
    if (!osmesa().make_current(ctx_, buffer_.data(), GL_UNSIGNED_BYTE, 1, 1))
      return make_error("gl.current", "OSMesaMakeCurrent failed");
    return {};
  }
  void release() override { osmesa().make_current(nullptr, nullptr, 0, 0, 0); }
  Result<void> setup() {
    if (auto r = make_current(); !r) return r;
    auto r = finish_setup(&osmesa_get_proc, false);
    release();
    return r;
  }

 private:
  OSMesaContext ctx_;
  std::vector<unsigned char> buffer_ = std::vector<unsigned char>(4, 0);
};

std::mutex& create_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

Result<std::unique_ptr<GlContext>> create_osmesa_context(GlFlavor flavor) {
  if (flavor == GlFlavor::gles) return make_error("gl.osmesa", "OSMesa offers no GLES contexts");
  std::lock_guard lock(create_mutex());
  const OsmesaLib& lib = osmesa();
  if (!lib.error.empty()) return make_error("gl.osmesa", lib.error);
  const int attribs[] = {kOsmesaFormat, kOsmesaRgba, kOsmesaProfile, kOsmesaCoreProfile,
                         kOsmesaMajor, 4, kOsmesaMinor, 5, 0};
  OSMesaContext c = lib.create(attribs, nullptr);
  if (!c) return make_error("gl.osmesa", "OSMesaCreateContextAttribs(GL 4.5 core) failed");
  auto ctx = std::make_unique<OsmesaContext>(c);
  if (auto r = ctx->setup(); !r) return r.error();
  return std::unique_ptr<GlContext>(std::move(ctx));
}

}  // namespace hdrd::shading

#include "shading/gl_api.hpp"

namespace hdrd::shading {

std::string GlApi::load(GetProc get_proc) {
#define HDRD_GL_LOAD(name, type)                                     \
  name = reinterpret_cast<type>(get_proc("gl" #name));               \
  if (name == nullptr) return "gl" #name;
  HDRD_GL_FUNCTIONS(HDRD_GL_LOAD)
#undef HDRD_GL_LOAD
  return {};
}

}  // namespace hdrd::shading

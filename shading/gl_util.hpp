// GL helpers on top of a GlApi table: owned object names, shader programs, error and
// framebuffer checks, the GLSL preamble that differs between GL 4.5 core and GLES 3.2.
// Every owned object must be destroyed while its context is current.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

#include "encode/result.hpp"
#include "shading/gl_api.hpp"

namespace hdrd::shading {

enum class GlKind { texture, buffer, framebuffer, renderbuffer, vertex_array, program };

// An owned GL name (move-only).
class GlName {
 public:
  GlName() = default;
  GlName(const GlApi* gl, GlKind kind, GLuint id) : gl_(gl), kind_(kind), id_(id) {}
  GlName(GlName&& o) noexcept { *this = std::move(o); }
  GlName& operator=(GlName&& o) noexcept {
    if (this != &o) {
      reset();
      gl_ = std::exchange(o.gl_, nullptr);
      kind_ = o.kind_;
      id_ = std::exchange(o.id_, 0u);
    }
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  ~GlName() { reset(); }
  void reset();
  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }

 private:
  const GlApi* gl_ = nullptr;
  GlKind kind_ = GlKind::texture;
  GLuint id_ = 0;
};

GlName gen_texture(const GlApi& gl);
GlName gen_buffer(const GlApi& gl);
GlName gen_framebuffer(const GlApi& gl);
GlName gen_renderbuffer(const GlApi& gl);
GlName gen_vertex_array(const GlApi& gl);

// "#version 450 core" or "#version 320 es" plus highp defaults for every sampler type
// (GLES fragment samplers default to lowp, which llvmpipe evaluates at fp16:
// platform-debian12.md §1 pitfall 3). Defines HDRD_GLES to 0 or 1.
std::string glsl_preamble(const GlApi& gl);

// Compiles and links; the error carries the driver's log and `label`.
Result<GlName> build_program(const GlApi& gl, std::string_view label, std::string_view vertex_source,
                             std::string_view fragment_source);

// The vertex shader of every full-screen pass: one triangle from gl_VertexID, uv in [0,1].
std::string_view fullscreen_vertex_body();

// GL error / framebuffer completeness as a Result naming `what`.
Result<void> check_gl(const GlApi& gl, std::string_view what);
Result<void> check_framebuffer(const GlApi& gl, std::string_view what);

// Sampler state in one call.
void set_sampling(const GlApi& gl, GLenum target, GLint min_filter, GLint mag_filter, GLint wrap);

}  // namespace hdrd::shading

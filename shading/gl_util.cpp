#include "shading/gl_util.hpp"

#include <vector>

#include <fmt/format.h>

namespace hdrd::shading {

void GlName::reset() {
  if (!gl_ || id_ == 0) return;
  switch (kind_) {
    case GlKind::texture: gl_->DeleteTextures(1, &id_); break;
    case GlKind::buffer: gl_->DeleteBuffers(1, &id_); break;
    case GlKind::framebuffer: gl_->DeleteFramebuffers(1, &id_); break;
    case GlKind::renderbuffer: gl_->DeleteRenderbuffers(1, &id_); break;
    case GlKind::vertex_array: gl_->DeleteVertexArrays(1, &id_); break;
    case GlKind::program: gl_->DeleteProgram(id_); break;
  }
  id_ = 0;
}

GlName gen_texture(const GlApi& gl) { GLuint id = 0; gl.GenTextures(1, &id); return {&gl, GlKind::texture, id}; }
GlName gen_buffer(const GlApi& gl) { GLuint id = 0; gl.GenBuffers(1, &id); return {&gl, GlKind::buffer, id}; }
GlName gen_framebuffer(const GlApi& gl) {
  GLuint id = 0;
  gl.GenFramebuffers(1, &id);
  return {&gl, GlKind::framebuffer, id};
}
GlName gen_renderbuffer(const GlApi& gl) {
  GLuint id = 0;
  gl.GenRenderbuffers(1, &id);
  return {&gl, GlKind::renderbuffer, id};
}
GlName gen_vertex_array(const GlApi& gl) {
  GLuint id = 0;
  gl.GenVertexArrays(1, &id);
  return {&gl, GlKind::vertex_array, id};
}

std::string glsl_preamble(const GlApi& gl) {
  if (!gl.gles) return "#version 450 core\n#define HDRD_GLES 0\n";
  return "#version 320 es\n#define HDRD_GLES 1\n"
         "precision highp float;\nprecision highp int;\n"
         "precision highp sampler2D;\nprecision highp sampler3D;\nprecision highp sampler2DArray;\n"
         "precision highp sampler2DShadow;\nprecision highp sampler2DMS;\nprecision highp samplerCube;\n"
         "precision highp usampler2D;\nprecision highp isampler2D;\n";
}

namespace {

Result<GLuint> compile(const GlApi& gl, GLenum type, std::string_view label, std::string_view source) {
  const GLuint s = gl.CreateShader(type);
  const char* text = source.data();
  const GLint len = static_cast<GLint>(source.size());
  gl.ShaderSource(s, 1, &text, &len);
  gl.CompileShader(s);
  GLint ok = 0;
  gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (ok) return s;
  GLint log_len = 0;
  gl.GetShaderiv(s, GL_INFO_LOG_LENGTH, &log_len);
  std::vector<char> log(static_cast<std::size_t>(std::max(log_len, 1)), '\0');
  gl.GetShaderInfoLog(s, log_len, nullptr, log.data());
  gl.DeleteShader(s);
  return make_error("gl.shader", fmt::format("{} {} shader does not compile: {}", label,
                                             type == GL_VERTEX_SHADER ? "vertex" : "fragment", log.data()));
}

}  // namespace

Result<GlName> build_program(const GlApi& gl, std::string_view label, std::string_view vertex_source,
                             std::string_view fragment_source) {
  auto vs = compile(gl, GL_VERTEX_SHADER, label, vertex_source);
  if (!vs) return vs.error();
  auto fs = compile(gl, GL_FRAGMENT_SHADER, label, fragment_source);
  if (!fs) {
    gl.DeleteShader(*vs);
    return fs.error();
  }
  GlName prog(&gl, GlKind::program, gl.CreateProgram());
  gl.AttachShader(prog.id(), *vs);
  gl.AttachShader(prog.id(), *fs);
  gl.LinkProgram(prog.id());
  gl.DeleteShader(*vs);
  gl.DeleteShader(*fs);
  GLint ok = 0;
  gl.GetProgramiv(prog.id(), GL_LINK_STATUS, &ok);
  if (ok) return prog;
  GLint log_len = 0;
  gl.GetProgramiv(prog.id(), GL_INFO_LOG_LENGTH, &log_len);
  std::vector<char> log(static_cast<std::size_t>(std::max(log_len, 1)), '\0');
  gl.GetProgramInfoLog(prog.id(), log_len, nullptr, log.data());
  return make_error("gl.shader", fmt::format("{} program does not link: {}", label, log.data()));
}

std::string_view fullscreen_vertex_body() {
  return R"(
out vec2 v_uv;
void main() {
  // One triangle covering the viewport: (-1,-1), (3,-1), (-1,3).
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  v_uv = p * 0.5 + 0.5;
  gl_Position = vec4(p, 0.0, 1.0);
}
)";
}

Result<void> check_gl(const GlApi& gl, std::string_view what) {
  const GLenum e = gl.GetError();
  if (e == GL_NO_ERROR) return {};
  while (gl.GetError() != GL_NO_ERROR) {
  }
  const char* name = e == GL_INVALID_ENUM ? "GL_INVALID_ENUM"
                     : e == GL_INVALID_VALUE ? "GL_INVALID_VALUE"
                     : e == GL_INVALID_OPERATION ? "GL_INVALID_OPERATION"
                     : e == GL_OUT_OF_MEMORY ? "GL_OUT_OF_MEMORY"
                     : e == GL_INVALID_FRAMEBUFFER_OPERATION ? "GL_INVALID_FRAMEBUFFER_OPERATION"
                                                              : "GL error";
  return make_error(e == GL_OUT_OF_MEMORY ? "gl.out_of_memory" : "gl.error",
                    fmt::format("{} failed: {} (0x{:x})", what, name, e));
}

Result<void> check_framebuffer(const GlApi& gl, std::string_view what) {
  const GLenum s = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
  if (s == GL_FRAMEBUFFER_COMPLETE) return {};
  return make_error("gl.framebuffer", fmt::format("{} framebuffer incomplete (0x{:x})", what, s));
}

void set_sampling(const GlApi& gl, GLenum target, GLint min_filter, GLint mag_filter, GLint wrap) {
  gl.TexParameteri(target, GL_TEXTURE_MIN_FILTER, min_filter);
  gl.TexParameteri(target, GL_TEXTURE_MAG_FILTER, mag_filter);
  gl.TexParameteri(target, GL_TEXTURE_WRAP_S, wrap);
  gl.TexParameteri(target, GL_TEXTURE_WRAP_T, wrap);
  if (target == GL_TEXTURE_3D || target == GL_TEXTURE_2D_ARRAY) gl.TexParameteri(target, GL_TEXTURE_WRAP_R, wrap);
}

}  // namespace hdrd::shading

#include "shading/gpu_pass.hpp"

#include <chrono>
#include <cstring>

#include <fmt/format.h>

#include "shading/renderer_impl.hpp"

namespace hdrd::shading {

struct GpuPass::State {
  GlName program, vao, ubo, target, fbo, image_input;
  std::vector<std::pair<GlName, GLenum>> textures;  // texture, target (unit = index + 1)
  std::vector<GLint> sampler_locations;
  GLint scene_location = -1, scale_location = -1, height_location = -1;
  PassOutput output = PassOutput::rgba32f;
  std::size_t block_size = 0;
  int target_width = 0, target_height = 0;
  std::string name;
};

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

struct OutputFormat {
  GLenum internal, format, type;
  const char* out_decl;
};

OutputFormat output_format(PassOutput o) {
  switch (o) {
    case PassOutput::rgba16f_bits: return {GL_RGBA16UI, GL_RGBA_INTEGER, GL_UNSIGNED_SHORT, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::rgb10a2ui: return {GL_RGB10_A2UI, GL_RGBA_INTEGER, GL_UNSIGNED_INT_2_10_10_10_REV, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::rgba8ui: return {GL_RGBA8UI, GL_RGBA_INTEGER, GL_UNSIGNED_BYTE, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::r32ui: return {GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::rg32ui: return {GL_RG32UI, GL_RG_INTEGER, GL_UNSIGNED_INT, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::rgba32ui: return {GL_RGBA32UI, GL_RGBA_INTEGER, GL_UNSIGNED_INT, "layout(location = 0) out uvec4 hdrd_out;\n"};
    case PassOutput::rgba32f: break;
  }
  return {GL_RGBA32F, GL_RGBA, GL_FLOAT, "layout(location = 0) out vec4 hdrd_out;\n"};
}

constexpr const char* kPassHeader = R"(
in vec2 v_uv;
uniform sampler2D hdrd_scene;
uniform float hdrd_scene_scale;
uniform int hdrd_height;
ivec2 hdrd_pixel() { return ivec2(int(gl_FragCoord.x), hdrd_height - 1 - int(gl_FragCoord.y)); }
// Codes computed here, not by the UNORM store (llvmpipe's is not exact round-to-nearest).
uvec4 hdrd_quantize(vec4 v, float max_code) { return uvec4(clamp(v, 0.0, 1.0) * max_code + 0.5); }
// packHalf2x16 rounds to nearest even (llvmpipe's float->half store rounds toward zero).
uint hdrd_half_bits(float v) { return packHalf2x16(vec2(v, 0.0)) & 0xFFFFu; }
)";

bool has_extension(const GlApi& gl, const char* name) {
  GLint n = 0;
  gl.GetIntegerv(GL_NUM_EXTENSIONS, &n);
  for (GLint i = 0; i < n; ++i) {
    const auto* e = reinterpret_cast<const char*>(gl.GetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
    if (e && std::strcmp(e, name) == 0) return true;
  }
  return false;
}

Result<std::pair<GlName, GLenum>> upload_table(const GlApi& gl, const PassTexture& t, const std::string& pass) {
  static const GLenum internal[] = {GL_R32F, GL_RG32F, GL_RGB32F, GL_RGBA32F};
  static const GLenum format[] = {GL_RED, GL_RG, GL_RGB, GL_RGBA};
  const std::string what = fmt::format("{}: texture '{}'", pass, t.sampler);
  if (t.channels < 1 || t.channels > 4 || t.dimensions < 1 || t.dimensions > 3 || t.width < 1 || t.height < 1 ||
      t.depth < 1 || (t.dimensions == 1 && (t.height != 1 || t.depth != 1)) || (t.dimensions == 2 && t.depth != 1))
    return make_error("gpu_pass.texture", what + " has an invalid shape");
  const std::size_t count = std::size_t(t.width) * t.height * t.depth * t.channels;
  if (t.data.size() != count)
    return make_error("gpu_pass.texture", fmt::format("{} has {} floats, its shape needs {}", what, t.data.size(), count));
  const GLenum target = t.dimensions == 3 ? GL_TEXTURE_3D : GL_TEXTURE_2D;
  GlName tex = gen_texture(gl);
  gl.BindTexture(target, tex.id());
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const GLenum in = internal[t.channels - 1], fmt_ = format[t.channels - 1];
  if (target == GL_TEXTURE_3D) {
    gl.TexStorage3D(target, 1, in, t.width, t.height, t.depth);
    gl.TexSubImage3D(target, 0, 0, 0, 0, t.width, t.height, t.depth, fmt_, GL_FLOAT, t.data.data());
  } else {
    gl.TexStorage2D(target, 1, in, t.width, t.height);
    gl.TexSubImage2D(target, 0, 0, 0, t.width, t.height, fmt_, GL_FLOAT, t.data.data());
  }
  const GLint filter = t.linear_filter ? GL_LINEAR : GL_NEAREST;
  set_sampling(gl, target, filter, filter, GL_CLAMP_TO_EDGE);
  if (auto e = check_gl(gl, what); !e) return e.error();
  return std::make_pair(std::move(tex), target);
}

Result<void> check_block(const GlApi& gl, GLuint program, const PassProgram& p) {
  if (p.block_name.empty()) return {};
  const GLuint index = gl.GetUniformBlockIndex(program, p.block_name.c_str());
  if (index == GL_INVALID_INDEX) {
    if (p.block_size == 0) return {};
    return make_error("gpu_pass.block", fmt::format("{}: the shader has no uniform block '{}'", p.name, p.block_name));
  }
  GLint size = 0;
  gl.GetActiveUniformBlockiv(program, index, GL_UNIFORM_BLOCK_DATA_SIZE, &size);
  // The C++ twin must have exactly the std140 size (its offsets are static_asserted).
  if (static_cast<std::size_t>(size) != p.block_size)
    return make_error("gpu_pass.block", fmt::format("{}: uniform block '{}' is {} bytes in GLSL, {} in C++", p.name,
                                                    p.block_name, size, p.block_size));
  gl.UniformBlockBinding(program, index, kPassUniformBinding);
  return {};
}

}  // namespace

std::size_t bytes_per_pixel(PassOutput o) {
  switch (o) {
    case PassOutput::rgba32f: return 16;
    case PassOutput::rgba16f_bits: return 8;
    case PassOutput::rgb10a2ui:
    case PassOutput::rgba8ui:
    case PassOutput::r32ui: return 4;
    case PassOutput::rg32ui: return 8;
    case PassOutput::rgba32ui: return 16;
  }
  return 16;
}

std::uint32_t PassResult::word(std::size_t pixel, int index) const {
  std::uint32_t w;
  std::memcpy(&w, bytes.data() + pixel * bytes_per_pixel(format) + index * 4, 4);
  return w;
}

std::uint16_t PassResult::half(std::size_t pixel, int channel) const {
  std::uint16_t h;
  std::memcpy(&h, bytes.data() + pixel * 8 + channel * 2, 2);
  return h;
}

GpuPass::GpuPass(Renderer& r, std::unique_ptr<State> s) : renderer_(r), state_(std::move(s)) {}

GpuPass::~GpuPass() {
  GlContext& ctx = *renderer_.impl().context;
  if (ctx.make_current()) {
    state_.reset();
    ctx.release();
  }
}

Result<std::unique_ptr<GpuPass>> GpuPass::compile(Renderer& renderer, const PassProgram& p) {
  Renderer::Impl& r = renderer.impl();
  CurrentContext current(*r.context);
  if (!current.status()) return current.status().error();
  const GlApi& gl = *r.gl;
  gl.GetError();
  auto state = std::make_unique<State>();
  state->output = p.output;
  state->block_size = p.block_size;
  state->name = p.name;
  const std::string fragment = glsl_preamble(gl) + kPassHeader + output_format(p.output).out_decl + p.fragment_source;
  const std::string vertex = glsl_preamble(gl) + std::string(fullscreen_vertex_body());
  auto prog = build_program(gl, p.name, vertex, fragment);
  if (!prog) return prog.error();
  state->program = std::move(*prog);
  if (auto e = check_block(gl, state->program.id(), p); !e) return e.error();
  const bool wants_linear = std::any_of(p.textures.begin(), p.textures.end(), [](const PassTexture& t) { return t.linear_filter; });
  if (gl.gles && wants_linear && !has_extension(gl, "GL_OES_texture_float_linear"))
    return make_error("gpu_pass.texture", p.name + ": this GLES driver cannot filter float textures (no GL_OES_texture_float_linear)");
  for (const PassTexture& t : p.textures) {
    auto tex = upload_table(gl, t, p.name);
    if (!tex) return tex.error();
    state->textures.push_back(std::move(*tex));
    state->sampler_locations.push_back(gl.GetUniformLocation(state->program.id(), t.sampler.c_str()));
    if (state->sampler_locations.back() < 0)
      return make_error("gpu_pass.texture", fmt::format("{}: the shader does not use sampler '{}'", p.name, t.sampler));
  }
  state->scene_location = gl.GetUniformLocation(state->program.id(), "hdrd_scene");
  state->scale_location = gl.GetUniformLocation(state->program.id(), "hdrd_scene_scale");
  state->height_location = gl.GetUniformLocation(state->program.id(), "hdrd_height");
  state->vao = gen_vertex_array(gl);
  if (p.block_size > 0) {
    state->ubo = gen_buffer(gl);
    gl.BindBuffer(GL_UNIFORM_BUFFER, state->ubo.id());
    gl.BufferData(GL_UNIFORM_BUFFER, static_cast<GLsizeiptr>(p.block_size), nullptr, GL_DYNAMIC_DRAW);
  }
  if (auto e = check_gl(gl, p.name + " set-up"); !e) return e.error();
  return std::unique_ptr<GpuPass>(new GpuPass(renderer, std::move(state)));
}

namespace {

Result<void> ensure_target(const GlApi& gl, GpuPass::State& s, int w, int h) {
  if (s.target && s.target_width == w && s.target_height == h) return {};
  s.target = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, s.target.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, output_format(s.output).internal, w, h);
  s.fbo = gen_framebuffer(gl);
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.fbo.id());
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, s.target.id(), 0);
  if (auto e = check_gl(gl, s.name + " target"); !e) return e;
  if (auto e = check_framebuffer(gl, s.name + " target"); !e) return e;
  s.target_width = w;
  s.target_height = h;
  return {};
}

// GLES guarantees only RGBA_INTEGER + UNSIGNED_INT for integer colour buffers (ES 3.2
// §16.1.2): read that and pack it into the output's layout. Desktop GL reads it directly.
void read_pixels(const GlApi& gl, PassOutput o, int w, int h, std::uint8_t* dst) {
  const OutputFormat f = output_format(o);
  if (!gl.gles || o == PassOutput::rgba32f || o == PassOutput::rgba32ui) {
    gl.ReadPixels(0, 0, w, h, f.format, f.type, dst);
    return;
  }
  const std::size_t n = static_cast<std::size_t>(w) * h;
  std::vector<std::uint32_t> v(n * 4);
  gl.ReadPixels(0, 0, w, h, GL_RGBA_INTEGER, GL_UNSIGNED_INT, v.data());
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t* p = v.data() + i * 4;
    switch (o) {
      case PassOutput::rgba16f_bits:
        for (int c = 0; c < 4; ++c) {
          const auto h16 = static_cast<std::uint16_t>(p[c]);
          std::memcpy(dst + i * 8 + c * 2, &h16, 2);
        }
        break;
      case PassOutput::rgb10a2ui: {
        const std::uint32_t word = (p[0] & 0x3ffu) | ((p[1] & 0x3ffu) << 10) | ((p[2] & 0x3ffu) << 20) | (p[3] << 30);
        std::memcpy(dst + i * 4, &word, 4);
        break;
      }
      case PassOutput::rgba8ui:
        for (int c = 0; c < 4; ++c) dst[i * 4 + c] = static_cast<std::uint8_t>(p[c]);
        break;
      case PassOutput::r32ui: std::memcpy(dst + i * 4, p, 4); break;
      case PassOutput::rg32ui: std::memcpy(dst + i * 8, p, 8); break;
      default: break;
    }
  }
}

Result<PassResult> execute(const GlApi& gl, GpuPass::State& s, GLuint input, int w, int h, double scale,
                           std::span<const std::byte> uniforms) {
  if (uniforms.size() != s.block_size)
    return make_error("gpu_pass.block", fmt::format("{}: {} uniform bytes given, the block has {}", s.name,
                                                    uniforms.size(), s.block_size));
  if (auto e = ensure_target(gl, s, w, h); !e) return e.error();
  const auto t0 = Clock::now();
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.fbo.id());
  gl.Viewport(0, 0, w, h);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_BLEND);
  gl.Disable(GL_CULL_FACE);
  gl.UseProgram(s.program.id());
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D, input);
  gl.Uniform1i(s.scene_location, 0);
  gl.Uniform1f(s.scale_location, static_cast<float>(scale));
  gl.Uniform1i(s.height_location, h);
  for (std::size_t i = 0; i < s.textures.size(); ++i) {
    gl.ActiveTexture(GL_TEXTURE1 + static_cast<GLenum>(i));
    gl.BindTexture(s.textures[i].second, s.textures[i].first.id());
    gl.Uniform1i(s.sampler_locations[i], static_cast<GLint>(i + 1));
  }
  if (s.block_size > 0) {
    gl.BindBuffer(GL_UNIFORM_BUFFER, s.ubo.id());
    gl.BufferSubData(GL_UNIFORM_BUFFER, 0, static_cast<GLsizeiptr>(uniforms.size()), uniforms.data());
    gl.BindBufferBase(GL_UNIFORM_BUFFER, kPassUniformBinding, s.ubo.id());
  }
  gl.BindVertexArray(s.vao.id());
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.Finish();
  PassResult out;
  out.gpu_ms = ms_since(t0);
  out.width = w;
  out.height = h;
  out.format = s.output;
  const auto t1 = Clock::now();
  const std::size_t row = static_cast<std::size_t>(w) * bytes_per_pixel(s.output);
  out.bytes.resize(row * h);
  gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  read_pixels(gl, s.output, w, h, out.bytes.data());
  std::vector<std::uint8_t> tmp(row);
  for (int y = 0; y < h / 2; ++y) {  // GL rows are bottom-up
    std::uint8_t* a = out.bytes.data() + static_cast<std::size_t>(y) * row;
    std::uint8_t* b = out.bytes.data() + static_cast<std::size_t>(h - 1 - y) * row;
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
  out.readback_ms = ms_since(t1);
  gl.BindVertexArray(0);
  gl.UseProgram(0);
  if (auto e = check_gl(gl, s.name); !e) return e.error();
  return out;
}

}  // namespace

Result<PassResult> GpuPass::run(std::span<const std::byte> uniforms) {
  Renderer::Impl& r = renderer_.impl();
  if (!r.has_frame) return make_error("gpu_pass.no_frame", state_->name + ": nothing rendered yet");
  CurrentContext current(*r.context);
  if (!current.status()) return current.status().error();
  return execute(*r.gl, *state_, r.targets.color.id(), r.targets.width, r.targets.height, 1.0 / r.last_pre_exposure,
                 uniforms);
}

Result<PassResult> GpuPass::run_on_image(const Image& image, std::span<const std::byte> uniforms) {
  if (auto e = check_image_size(image.width, image.height); !e) return e.error();
  if (image.rgba.size() != image.pixel_count() * 4) return make_error("gpu_pass.input", "image buffer has the wrong size");
  Renderer::Impl& r = renderer_.impl();
  CurrentContext current(*r.context);
  if (!current.status()) return current.status().error();
  const GlApi& gl = *r.gl;
  // Upload bottom-up so that texel (x, y) is gl_FragCoord (x, y) and rows read back top-down.
  std::vector<float> flipped(image.rgba.size());
  const std::size_t row = static_cast<std::size_t>(image.width) * 4;
  for (int y = 0; y < image.height; ++y)
    std::memcpy(flipped.data() + static_cast<std::size_t>(image.height - 1 - y) * row,
                image.rgba.data() + static_cast<std::size_t>(y) * row, row * sizeof(float));
  state_->image_input = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, state_->image_input.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, image.width, image.height);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGBA, GL_FLOAT, flipped.data());
  set_sampling(gl, GL_TEXTURE_2D, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  if (auto e = check_gl(gl, state_->name + " input upload"); !e) return e.error();
  return execute(gl, *state_, state_->image_input.id(), image.width, image.height, 1.0, uniforms);
}

}  // namespace hdrd::shading

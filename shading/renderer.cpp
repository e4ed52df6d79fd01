#include "shading/renderer.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

#include <fmt/format.h>

#include "shading/brdf.hpp"
#include "shading/renderer_impl.hpp"
#include "shading/shaders.hpp"

namespace hdrd::shading {
namespace {

// The split-sum table of brdf::ambient_terms, baked once per process from the CPU BRDF.
const std::vector<float>& ambient_lut_data() {
  static const std::vector<float> data = [] {
    const int n = gpu::kAmbientLutSize;
    std::vector<float> d(static_cast<std::size_t>(n) * n * 4, 0.0f);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const auto t = brdf::ambient_terms(double(i) / (n - 1), double(j) / (n - 1), 1024);
        // The sampling error (< 2e-3) must not push the albedo above 1 (eq. 9.8).
        const double spec = std::min(1.0, t.s0 + t.s1) / std::max(1e-12, t.s0 + t.s1);
        float* p = d.data() + (static_cast<std::size_t>(j) * n + i) * 4;
        p[0] = float(t.s0 * spec);
        p[1] = float(t.s1 * spec);
        p[2] = float(std::clamp(t.d1, 0.0, 1.0));
      }
    return d;
  }();
  return data;
}

Result<void> init_impl(Renderer::Impl& r) {
  const GlApi& gl = *r.gl;
  auto lit = build_program(gl, "lit", shaders::lit_vertex(gl), shaders::lit_fragment(gl));
  if (!lit) return lit.error();
  r.lit_program = std::move(*lit);
  auto shadow = build_program(gl, "shadow", shaders::shadow_vertex(gl), shaders::shadow_fragment(gl));
  if (!shadow) return shadow.error();
  r.shadow_program = std::move(*shadow);
  auto resolve = build_program(gl, "resolve", shaders::fullscreen_vertex(gl), shaders::resolve_fragment(gl));
  if (!resolve) return resolve.error();
  r.resolve_program = std::move(*resolve);
  auto reduce = build_program(gl, "reduce", shaders::fullscreen_vertex(gl), shaders::reduce_fragment(gl));
  if (!reduce) return reduce.error();
  r.reduce_program = std::move(*reduce);
  if (auto ibl = init_ibl(r); !ibl) return ibl;
  r.reduce_block_loc = gl.GetUniformLocation(r.reduce_program.id(), "u_block");
  r.reduce_size_loc = gl.GetUniformLocation(r.reduce_program.id(), "u_size");
  r.reduce_scale_loc = gl.GetUniformLocation(r.reduce_program.id(), "u_scale");
  r.resolve_samples_loc = gl.GetUniformLocation(r.resolve_program.id(), "u_samples");
  r.resolve_exposure_loc = gl.GetUniformLocation(r.resolve_program.id(), "u_weight_exposure");
  gl.GetIntegerv(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &r.ubo_alignment);

  const int n = gpu::kAmbientLutSize;
  r.ambient_lut = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, r.ambient_lut.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, n, n);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, n, n, GL_RGBA, GL_FLOAT, ambient_lut_data().data());
  set_sampling(gl, GL_TEXTURE_2D, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);

  const std::uint8_t white[4] = {255, 255, 255, 255};
  r.white_texture = gen_texture(gl);
  gl.BindTexture(GL_TEXTURE_2D, r.white_texture.id());
  gl.TexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, 1, 1);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white);
  set_sampling(gl, GL_TEXTURE_2D, GL_NEAREST, GL_NEAREST, GL_REPEAT);
  r.empty_vao = gen_vertex_array(gl);
  return check_gl(gl, "renderer set-up");
}

}  // namespace

Renderer::Renderer(std::unique_ptr<GlContext> c, std::unique_ptr<Impl> impl)
    : context_(std::move(c)), impl_(std::move(impl)) {}

Renderer::~Renderer() {
  // GL objects die with the context current.
  if (context_ && context_->make_current()) {
    impl_.reset();
    context_->release();
  }
}

Result<std::unique_ptr<Renderer>> Renderer::create(Backend backend) {
  return create(ContextOptions{backend, GlFlavor::automatic});
}

Result<std::unique_ptr<Renderer>> Renderer::create(const ContextOptions& options) {
  auto ctx = GlContext::create(options);
  if (!ctx) return ctx.error();
  auto impl = std::make_unique<Impl>();
  impl->context = ctx->get();
  impl->gl = &(*ctx)->gl();
  {
    CurrentContext current(**ctx);
    if (!current.status()) return current.status().error();
    if (auto r = init_impl(*impl); !r) {
      impl.reset();
      return r.error();
    }
  }
  return std::unique_ptr<Renderer>(new Renderer(std::move(*ctx), std::move(impl)));
}

Result<CameraOverride> parse_camera_override(std::string_view text) {
  CameraOverride c;
  auto parse_vec = [](std::string_view s, Vec3& out) {
    double v[3];
    std::string buf(s);
    char extra = 0;
    if (std::sscanf(buf.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &extra) != 3) return false;
    out = {v[0], v[1], v[2]};
    return is_finite(out);
  };
  const auto bad = [&] {
    return make_error("camera.syntax",
                      fmt::format("camera '{}' is not \"px,py,pz[:tx,ty,tz[:fov_deg]]\"", text), "camera");
  };
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const auto colon = text.find(':', start);
    parts.push_back(text.substr(start, colon == std::string_view::npos ? colon : colon - start));
    if (colon == std::string_view::npos) break;
    start = colon + 1;
  }
  if (parts.size() > 3) return bad();
  Vec3 p;
  if (!parse_vec(parts[0], p)) return bad();
  c.position = p;
  if (parts.size() >= 2) {
    if (!parse_vec(parts[1], p)) return bad();
    c.target = p;
  }
  if (parts.size() == 3) {
    std::string buf(parts[2]);
    char* end = nullptr;
    const double fov = std::strtod(buf.c_str(), &end);
    if (end == buf.c_str() || *end != '\0' || !(fov > 0 && fov < 180)) return bad();
    c.yfov_deg = fov;
  }
  return c;
}

double dynamic_range_stops(const Image& frame, double low, double high) {
  std::vector<float> lum;
  lum.reserve(frame.pixel_count());
  for (std::size_t i = 0; i < frame.pixel_count(); ++i) {
    const float* p = frame.rgba.data() + i * 4;
    const float y = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
    if (y > 0 && std::isfinite(y)) lum.push_back(y);
  }
  if (lum.size() < 2) return 0;
  auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * double(lum.size() - 1));
    std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(k), lum.end());
    return double(lum[k]);
  };
  const double lo = at(low), hi = at(high);
  return std::log2(hi / lo);
}

}  // namespace hdrd::shading

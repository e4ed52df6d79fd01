// The README's environment-light pictures (docs/img/), through the library until
// `hdrd render --environment` exists: the material-grid scene under its Preetham sky and
// under a studio environment written here as an OpenEXR file (2048x1024, whiteLuminance
// 100), each encoded for SDR (sRGB, light-based exposure) and as the heatmap of the HDR10
// display luminance (what `hdrd render --debug heatmap` writes).
//   build/bench/bench_render_pictures OUTDIR      (scripts/make-docs-pictures.sh)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "patterns/plot.hpp"
#include "shading/environment.hpp"
#include "shading/renderer.hpp"

namespace {

using namespace hdrd;
using namespace hdrd::shading;

// A photographer's studio: dim walls and floor, a large softbox up front left, a strip
// light on the right, a warm kicker behind and a sky-blue overhead, in cd/m2.
Vec3 studio(Vec3 d) {
  const auto box = [&](double az_deg, double el_deg, double half_w_deg, double half_h_deg) {
    const double az = std::atan2(d.x, -d.z) * 180 / kPi, el = std::asin(std::clamp(d.y, -1.0, 1.0)) * 180 / kPi;
    double da = std::abs(az - az_deg);
    da = std::min(da, 360 - da);
    const auto soft = [](double x) { return std::clamp(1.5 - x * 1.5, 0.0, 1.0); };  // a soft edge
    return soft(da / half_w_deg) * soft(std::abs(el - el_deg) / half_h_deg);
  };
  Vec3 c = d.y < 0 ? Vec3{12, 11, 10} : Vec3{30, 30, 32} * (1 + d.y);
  c = c + Vec3{6000, 6000, 5800} * box(-40, 25, 22, 18);
  c = c + Vec3{3500, 3700, 4000} * box(75, 10, 6, 30);
  c = c + Vec3{9000, 6500, 4000} * box(170, 15, 8, 8);
  c = c + Vec3{400, 550, 800} * std::pow(std::max(0.0, d.y), 8);
  return c;
}

bool write_studio(const std::filesystem::path& path) {
  Image img(2048, 1024);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Vec3 c = studio(equirect_direction((x + 0.5) / img.width, (y + 0.5) / img.height)) / 100.0;
      float* p = img.px(x, y);
      p[0] = float(c.x), p[1] = float(c.y), p[2] = float(c.z), p[3] = 1;
    }
  io::ExrWriteOptions o;
  o.half = true;
  o.white_luminance = 100;  // value x 100 = cd/m2
  auto r = io::write_exr(path, img, o);
  if (!r) std::fprintf(stderr, "%s\n", r.error().message.c_str());
  return r.ok();
}

bool write_bytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return bool(f);
}

Result<EncodedFrame> encode(const RenderResult& r, Mode mode) {
  SceneInput in;
  in.image = &r.scene_nits;
  in.units = InputUnits::absolute;
  in.illuminance_lux = r.dominant_illuminance_lux;
  EncodeSettings s;
  s.target = default_target(mode);
  s.exposure.mode = exposure::Mode::light;
  auto prepared = prepare_pipeline(in, s);
  if (!prepared) return prepared.error();
  return encode_prepared(in, *prepared);
}

bool picture(Renderer& renderer, const std::string& name, const std::optional<EnvironmentSpec>& env,
             const std::filesystem::path& dir) {
  RenderRequest q;
  q.scene = "material-grid";
  q.width = 960;
  q.height = 540;
  q.samples = 4;
  q.environment = env;
  auto r = renderer.render(q);
  if (!r) return std::fprintf(stderr, "%s: %s\n", name.c_str(), r.error().message.c_str()), false;
  for (const auto& w : r->warnings) std::fprintf(stderr, "%s: warning: %s\n", name.c_str(), w.c_str());
  auto sdr = encode(*r, Mode::sdr);
  auto hdr = encode(*r, Mode::hdr10);
  if (!sdr || !hdr) return std::fprintf(stderr, "%s: encode failed\n", name.c_str()), false;
  auto png = io::encode_png(*sdr);
  auto heat = patterns::frame_heatmap(*hdr).png();
  if (!png || !heat) return false;
  std::printf("%s: %s, metered %.0f lux, environment %.0f ms, frame %.0f ms\n", name.c_str(), r->environment.c_str(),
              r->dominant_illuminance_lux, r->environment_ms, r->render_ms);
  return write_bytes(dir / (name + "-sdr.png"), *png) && write_bytes(dir / (name + "-hdr10-heatmap.png"), *heat);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return std::fprintf(stderr, "usage: %s OUTDIR\n", argv[0]), 2;
  const std::filesystem::path dir = argv[1];
  std::filesystem::create_directories(dir);
  auto renderer = Renderer::create(Backend::automatic);
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().message.c_str()), 1;
  const auto exr = dir / "studio-environment.exr";
  if (!write_studio(exr)) return 1;
  EnvironmentSpec studio_env;
  studio_env.file = exr;
  const bool ok = picture(**renderer, "material-grid-sky", std::nullopt, dir) &&
                  picture(**renderer, "material-grid-studio", studio_env, dir);
  return ok ? 0 : 1;
}

#include "shading/environment.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "encode/colour/color.hpp"
#include "encode/io/io.hpp"
#include "shading/radiance_hdr.hpp"
#include "shading/sky.hpp"

namespace hdrd::shading {
namespace {

Error spec_error(std::string_view field, std::string_view key, const std::string& what) {
  const std::string f = fmt::format("{}.{}", field, key);
  return make_error("environment.invalid", fmt::format("{}: {}", f, what), f);
}

bool in_range(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

Result<void> validate_sky(const SkyParams& s, std::string_view field) {
  const std::string f = fmt::format("{}.sky", field);
  if (!in_range(s.sun_elevation_deg, 0, 90))
    return spec_error(f, "sun_elevation_deg", "must be in [0, 90] (the Preetham sky is defined for a sun above the horizon)");
  if (!in_range(s.sun_azimuth_deg, -360, 360)) return spec_error(f, "sun_azimuth_deg", "must be in [-360, 360]");
  if (!in_range(s.turbidity, 1.7, 10)) return spec_error(f, "turbidity", "must be in [1.7, 10]");
  if (!in_range(s.ground_albedo, 0, 1)) return spec_error(f, "ground_albedo", "must be in [0, 1]");
  return {};
}

// Linear map of the file's RGB (or XYZ) into the renderer's Rec.709.
color::Mat3 exr_to_rec709(const io::ExrImage& e) {
  return color::rgb_to_rgb(color::kRec2020, color::kRec709) * e.to_working();
}

color::Mat3 radiance_to_rec709(const RadianceImage& r) {
  if (r.xyz) return color::xyz_to_rgb(color::kRec709);
  return r.primaries ? color::rgb_to_rgb(*r.primaries, color::kRec709) : color::Mat3::identity();
}

// RGBA floats -> the map's RGB, through `m` and times `gain`; NaN/Inf/negative -> 0.
EnvironmentMap convert(const Image& img, const color::Mat3& m, double gain, std::vector<std::string>& warnings) {
  EnvironmentMap out;
  out.width = img.width;
  out.height = img.height;
  out.rgb.resize(img.pixel_count() * 3);
  std::size_t non_finite = 0, negative = 0;
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    const float* p = img.rgba.data() + i * 4;
    float* o = out.rgb.data() + i * 3;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      ++non_finite;
      o[0] = o[1] = o[2] = 0;
      continue;
    }
    const color::Vec3 v = m * color::Vec3{p[0], p[1], p[2]};
    bool below = false;
    for (int c = 0; c < 3; ++c) {
      const double x = v[c] * gain;
      below |= x < 0;
      o[c] = static_cast<float>(std::isfinite(x) ? std::max(x, 0.0) : 0.0);
    }
    negative += below;
  }
  if (non_finite) warnings.push_back(fmt::format("environment: {} pixels with NaN or infinite values set to 0", non_finite));
  if (negative)
    warnings.push_back(fmt::format("environment: {} pixels with negative values (outside Rec.709) clamped to 0", negative));
  return out;
}

constexpr int kMinEnvironmentRows = 4;

Result<void> check_layout(const EnvironmentMap& m, const std::filesystem::path& path, std::vector<std::string>& warnings) {
  // Two rules, each with its own message: a 4x2 map is 2:1 and was refused as if it were not.
  const double aspect = double(m.width) / m.height;
  if (aspect < 1.5 || aspect > 2.5)
    return make_error("environment.layout",
                      fmt::format("'{}' is {}x{}: an equirectangular environment map is about twice as wide as high "
                                  "(1.5 to 2.5 : 1)",
                                  path.filename().string(), m.width, m.height),
                      "environment.file");
  if (m.height < kMinEnvironmentRows)
    return make_error("environment.layout",
                      fmt::format("'{}' is {}x{}: an environment map needs at least {} rows ({}x{} or larger)",
                                  path.filename().string(), m.width, m.height, kMinEnvironmentRows,
                                  2 * kMinEnvironmentRows, kMinEnvironmentRows),
                      "environment.file");
  if (m.width != 2 * m.height)
    warnings.push_back(fmt::format("environment '{}' is {}x{}, not 2:1; mapped as equirectangular anyway",
                                   path.filename().string(), m.width, m.height));
  return {};
}

double max_luminance(const EnvironmentMap& m) {
  double best = 0;
  for (std::size_t i = 0; i < m.rgb.size(); i += 3) best = std::max(best, luminance({m.rgb[i], m.rgb[i + 1], m.rgb[i + 2]}));
  return best;
}

}  // namespace

Result<void> validate_environment_spec(const EnvironmentSpec& spec, std::string_view field) {
  if (spec.file.empty() == !spec.sky.has_value())
    return make_error("environment.invalid", fmt::format("{}: give exactly one of file and sky", field), std::string(field));
  if (!in_range(spec.scale, 0, 1e9)) return spec_error(field, "scale", "must be in [0, 1e9]");
  if (!in_range(spec.rotation_deg, -3600, 3600)) return spec_error(field, "rotation_deg", "must be in [-3600, 3600]");
  if (spec.sky) return validate_sky(*spec.sky, field);
  return {};
}

Result<SkyParams> parse_sky(std::string_view text) {
  const auto bad = [&] {
    return make_error("environment.sky_syntax", fmt::format("sky '{}' is not \"ELEV[,AZIM[,TURBIDITY]]\" (degrees)", text),
                      "sky");
  };
  std::vector<double> v;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string part(text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    char* end = nullptr;
    const double x = std::strtod(part.c_str(), &end);
    if (part.empty() || end != part.c_str() + part.size() || v.size() == 3) return bad();
    v.push_back(x);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  SkyParams s;
  s.sun_elevation_deg = v[0];
  if (v.size() >= 2) s.sun_azimuth_deg = v[1];
  if (v.size() >= 3) s.turbidity = v[2];
  if (auto r = validate_sky(s, "environment"); !r) return r.error();
  return s;
}

Vec3 direction_from_angles(double azimuth_rad, double elevation_rad) {
  const double c = std::cos(elevation_rad);
  return {std::sin(azimuth_rad) * c, std::sin(elevation_rad), -std::cos(azimuth_rad) * c};
}

std::array<double, 2> equirect_uv(Vec3 d) {
  // 0.0 - z, not -z: at the poles atan2(0, -0) would be pi.
  return {0.5 + std::atan2(d.x, 0.0 - d.z) / (2 * kPi), std::acos(std::clamp(d.y, -1.0, 1.0)) / kPi};
}

Vec3 equirect_direction(double u, double v) {
  const double theta = v * kPi;
  return direction_from_angles((u - 0.5) * 2 * kPi, kPi / 2 - theta);
}

Mat4 environment_rotation(double rotation_deg) {
  // World azimuth a must look up the file at azimuth a - rotation_deg; a right-handed turn
  // by rotation_deg about +y does that (x' = x cos b + z sin b, z' = z cos b - x sin b).
  return rotate_xyz_deg({0, rotation_deg, 0});
}

const std::array<CubeFace, 6>& cube_faces() {
  static const std::array<CubeFace, 6> faces = {{
      {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}},   // +X: sc = -z, tc = -y
      {{-1, 0, 0}, {0, 0, 1}, {0, -1, 0}},   // -X: sc = +z, tc = -y
      {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},     // +Y: sc = +x, tc = +z
      {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}},   // -Y: sc = +x, tc = -z
      {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}},    // +Z: sc = +x, tc = -y
      {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}},  // -Z: sc = -x, tc = -y
  }};
  return faces;
}

Vec3 cube_direction(int face, double s, double t) {
  const CubeFace& f = cube_faces()[static_cast<std::size_t>(face)];
  return normalize(f.major + f.s_axis * (2 * s - 1) + f.t_axis * (2 * t - 1));
}

Vec3 EnvironmentMap::texel(int x, int y) const {
  const float* p = rgb.data() + (static_cast<std::size_t>(y) * width + x) * 3;
  return {p[0], p[1], p[2]};
}

Vec3 EnvironmentMap::sample(Vec3 direction) const {
  const auto [u, v] = equirect_uv(normalize(direction));
  const double fx = u * width - 0.5, fy = std::clamp(v * height - 0.5, 0.0, double(height - 1));
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const double tx = fx - x0, ty = fy - y0;
  const int y1 = std::min(y0 + 1, height - 1);
  const auto wrap = [&](int x) { return ((x % width) + width) % width; };
  const Vec3 a = texel(wrap(x0), y0) * (1 - tx) + texel(wrap(x0 + 1), y0) * tx;
  const Vec3 b = texel(wrap(x0), y1) * (1 - tx) + texel(wrap(x0 + 1), y1) * tx;
  return a * (1 - ty) + b * ty;
}

RadianceGrid reduce_to_grid(const EnvironmentMap& map, int width, int height) {
  RadianceGrid g;
  g.width = width;
  g.height = height;
  const std::size_t n = static_cast<std::size_t>(width) * height;
  g.radiance.assign(n, Vec3{});
  g.direction.resize(n);
  g.solid_angle_sr.resize(n);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      g.direction[i] = equirect_direction((x + 0.5) / width, (y + 0.5) / height);
      g.solid_angle_sr[i] = (std::cos(kPi * y / height) - std::cos(kPi * (y + 1) / height)) * 2 * kPi / width;
    }
  if (map.width >= width && map.height >= height) {
    // Each source texel, weighted by its solid angle, into the cell holding its centre.
    std::vector<double> weight(n, 0.0);
    for (int y = 0; y < map.height; ++y) {
      const double w = std::cos(kPi * y / map.height) - std::cos(kPi * (y + 1) / map.height);
      const int gy = std::min(height - 1, static_cast<int>((y + 0.5) * height / map.height));
      for (int x = 0; x < map.width; ++x) {
        const int gx = std::min(width - 1, static_cast<int>((x + 0.5) * width / map.width));
        const std::size_t i = static_cast<std::size_t>(gy) * width + gx;
        g.radiance[i] = g.radiance[i] + map.texel(x, y) * w;
        weight[i] += w;
      }
    }
    for (std::size_t i = 0; i < n; ++i) g.radiance[i] = weight[i] > 0 ? g.radiance[i] / weight[i] : Vec3{};
  } else {
    // A small map: 4x4 bilinear samples per cell.
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        Vec3 sum{0, 0, 0};
        for (int k = 0; k < 16; ++k)
          sum = sum + map.sample(equirect_direction((x + (k % 4 + 0.5) / 4) / width, (y + (k / 4 + 0.5) / 4) / height));
        g.radiance[static_cast<std::size_t>(y) * width + x] = sum / 16.0;
      }
  }
  return g;
}

Vec3 irradiance_lux(const RadianceGrid& grid, Vec3 normal) {
  Vec3 sum{0, 0, 0};
  for (std::size_t i = 0; i < grid.radiance.size(); ++i) {
    const double c = dot(grid.direction[i], normal);
    if (c > 0) sum = sum + grid.radiance[i] * (c * grid.solid_angle_sr[i]);
  }
  return sum;
}

IrradianceCube irradiance_cube(const RadianceGrid& grid, int size) {
  // The quadrature of irradiance_lux() in float, cells as structure-of-arrays with the
  // solid angle folded into the radiance, padded to lanes of 8 with empty cells so that
  // the inner loop vectorises without reordering a float sum.
  constexpr std::size_t kLanes = 8;
  const std::size_t n = (grid.radiance.size() + kLanes - 1) / kLanes * kLanes;
  std::vector<float> dx(n, 0), dy(n, 0), dz(n, 0), lr(n, 0), lg(n, 0), lb(n, 0);
  for (std::size_t i = 0; i < grid.radiance.size(); ++i) {
    dx[i] = float(grid.direction[i].x), dy[i] = float(grid.direction[i].y), dz[i] = float(grid.direction[i].z);
    const Vec3 w = grid.radiance[i] * grid.solid_angle_sr[i];
    lr[i] = float(w.x), lg[i] = float(w.y), lb[i] = float(w.z);
  }
  IrradianceCube cube;
  cube.size = size;
  const auto face = [&](int f) {
    cube.faces[f].resize(static_cast<std::size_t>(size) * size);
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        const Vec3 d = cube_direction(f, (i + 0.5) / size, (j + 0.5) / size);
        const float nx = float(d.x), ny = float(d.y), nz = float(d.z);
        float r[kLanes] = {}, g[kLanes] = {}, b[kLanes] = {};
        for (std::size_t k = 0; k < n; k += kLanes)
          for (std::size_t l = 0; l < kLanes; ++l) {
            const float c = std::max(0.0f, nx * dx[k + l] + ny * dy[k + l] + nz * dz[k + l]);
            r[l] += c * lr[k + l];
            g[l] += c * lg[k + l];
            b[l] += c * lb[k + l];
          }
        Vec3 e{0, 0, 0};
        for (std::size_t l = 0; l < kLanes; ++l) e = e + Vec3{r[l], g[l], b[l]};
        cube.faces[f][static_cast<std::size_t>(j) * size + i] = e;
      }
  };
  // One face a thread (the work is 6 x size^2 x cells multiply-adds: 50 M at the defaults).
  std::vector<std::thread> threads;
  const int workers = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 6u));
  for (int t = 1; t < workers; ++t)
    threads.emplace_back([&, t] {
      for (int f = t; f < 6; f += workers) face(f);
    });
  for (int f = 0; f < 6; f += workers) face(f);
  for (auto& t : threads) t.join();
  return cube;
}

double IrradianceCube::max_illuminance_lux() const {
  double best = 0;
  for (const auto& face : faces)
    for (const Vec3& e : face) best = std::max(best, luminance(e));
  return best;
}

Vec3 IrradianceCube::lookup(Vec3 d) const {
  // The GL face selection of table 8.19, nearest texel.
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  int f = 0;
  if (ax >= ay && ax >= az) f = d.x >= 0 ? 0 : 1;
  else if (ay >= az) f = d.y >= 0 ? 2 : 3;
  else f = d.z >= 0 ? 4 : 5;
  const CubeFace& face = cube_faces()[static_cast<std::size_t>(f)];
  const double ma = dot(d, face.major);
  const double s = (dot(d, face.s_axis) / ma + 1) / 2, t = (dot(d, face.t_axis) / ma + 1) / 2;
  const int i = std::clamp(static_cast<int>(s * size), 0, size - 1), j = std::clamp(static_cast<int>(t * size), 0, size - 1);
  return faces[static_cast<std::size_t>(f)][static_cast<std::size_t>(j) * size + i];
}

Result<EnvironmentMap> load_environment_map(const std::filesystem::path& path, std::vector<std::string>& warnings,
                                           const io::InputFiles& files) {
  // Read once, through the file model; both decoders then parse these bytes.
  auto file = files.read(path, std::size_t{4} << 30);
  if (!file) return io::reader_error(file.error(), "environment.file", "environment.file", "environment.file");
  if (file->size() < 4)
    return make_error("environment.format", fmt::format("'{}' is too short to be an image", path.string()), "environment.file");
  const std::span bytes(reinterpret_cast<const std::uint8_t*>(file->data()), file->size());
  const auto* magic = bytes.data();
  EnvironmentMap map;
  if (magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01) {
    auto exr = io::read_exr_memory(bytes, {}, path.string());
    if (!exr) return make_error(exr.error().code, exr.error().message, "environment.file");
    for (auto& w : exr->warnings) warnings.push_back(fmt::format("environment: {}", w));
    if (!exr->white_luminance)
      warnings.push_back(fmt::format("environment '{}' has no whiteLuminance: its values are read as cd/m2 (times scale)",
                                     path.filename().string()));
    map = convert(exr->image, exr_to_rec709(*exr), exr->white_luminance.value_or(1.0), warnings);
  } else if (magic[0] == '#' && magic[1] == '?') {
    auto hdr = read_radiance_hdr_memory(bytes);
    if (!hdr)
      return make_error(hdr.error().code, fmt::format("{}: {}", path.filename().string(), hdr.error().message),
                        hdr.error().field);
    for (auto& w : hdr->warnings) warnings.push_back(fmt::format("environment: {}", w));
    map = convert(hdr->image, radiance_to_rec709(*hdr), 1.0, warnings);
  } else {
    return make_error("environment.format",
                      fmt::format("'{}' is neither OpenEXR nor a Radiance picture (.hdr)", path.filename().string()),
                      "environment.file");
  }
  if (auto r = check_layout(map, path, warnings); !r) return r.error();
  return map;
}

Result<EnvironmentLighting> build_environment(const EnvironmentSpec& spec) {
  if (auto r = validate_environment_spec(spec); !r) return r.error();
  EnvironmentLighting out;
  if (spec.sky) {
    const SkyParams& sky = *spec.sky;
    out.description = fmt::format("Preetham sky (sun elevation {:g} deg, turbidity {:g})", sky.sun_elevation_deg, sky.turbidity);
    out.map = make_sky_map(sky);
    if (sky.sun) out.sun = preetham_sun(sky);
  } else {
    out.description = spec.file.filename().string();
    auto map = load_environment_map(spec.file, out.warnings, spec.files);
    if (!map) return map.error();
    out.map = std::move(*map);
  }
  out.irradiance = irradiance_cube(reduce_to_grid(out.map));
  out.max_luminance_nits = std::max(max_luminance(out.map), out.sun ? out.sun->disc_luminance_nits : 0.0);
  return out;
}

std::string environment_cache_key(const EnvironmentSpec& spec) {
  if (spec.sky)
    return fmt::format("sky:{:.17g}:{:.17g}:{:.17g}:{}", spec.sky->sun_elevation_deg, spec.sky->turbidity,
                       spec.sky->ground_albedo, spec.sky->sun);
  std::error_code ec;
  const auto canonical = std::filesystem::weakly_canonical(spec.file, ec);
  const auto size = std::filesystem::file_size(spec.file, ec);
  const auto mtime = std::filesystem::last_write_time(spec.file, ec);
  return fmt::format("file:{}:{}:{}", (ec ? spec.file : canonical).string(), ec ? 0 : size,
                     ec ? 0 : mtime.time_since_epoch().count());
}

}  // namespace hdrd::shading

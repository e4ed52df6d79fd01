// Light from the world: equirectangular environment maps (OpenEXR, Radiance HDR) and the
// built-in analytic sky (shading/sky.hpp), in absolute cd/m2, linear Rec.709.
//
// Conventions (docs/rendering.md, "Environment light"):
// * Directions are world space, y up. The azimuth of a direction d is measured in the
//   horizontal plane from -z (where the default camera looks) toward +x:
//   azimuth = atan2(d.x, -d.z), elevation = asin(d.y).
// * Equirectangular maps: u = 0.5 + azimuth / 360 deg (the image centre lies at -z, u grows
//   to the right as seen from a camera looking at -z), v = zenith angle / 180 deg (the top
//   row is straight up). Rows are stored top-down.
// * rotation_deg turns the environment about the vertical axis in the sense of growing
//   azimuth: what the file shows at azimuth a appears at a + rotation_deg.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"
#include "shading/math.hpp"

namespace hdrd::shading {

// The built-in sky (Preetham, Shirley & Smits 1999) and its sun.
struct SkyParams {
  double sun_elevation_deg = 45;  // [0, 90]: the model is defined for a sun above the horizon
  double sun_azimuth_deg = 0;     // from -z toward +x
  double turbidity = 2.5;         // [1.7, 10]: 2 very clear, 3 clear, 6 hazy, 10 very hazy
  double ground_albedo = 0.2;     // [0, 1]: the lower hemisphere is a Lambertian ground lit by sun and sky
  bool sun = true;                // the sun as a shadowing directional light and as a disc in the background
};

// Where the light of the world comes from: a file or the sky, with a scale and a rotation.
struct EnvironmentSpec {
  std::filesystem::path file;    // equirectangular .exr / .hdr (exactly one of file and sky)
  std::optional<SkyParams> sky;
  // Multiplies the radiance. OpenEXR: value x whiteLuminance (when the file has it) x scale
  // = cd/m2; files without whiteLuminance and Radiance pictures: value x scale = cd/m2.
  double scale = 1.0;
  double rotation_deg = 0;
  // Where `file` is opened, at the moment it is read (encode/io/beneath.hpp): beneath the
  // daemon's asset root, or as given.
  io::InputFiles files;
};

// Checks ranges and that exactly one source is given; `field` prefixes error fields.
Result<void> validate_environment_spec(const EnvironmentSpec& spec, std::string_view field = "environment");

// "ELEV[,AZIM[,TURBIDITY]]" in degrees, e.g. "35,120,3" (the CLI's --sky).
Result<SkyParams> parse_sky(std::string_view text);

// ---- Directions ------------------------------------------------------------------------
Vec3 direction_from_angles(double azimuth_rad, double elevation_rad);
// Equirectangular texture coordinates of a unit direction and back.
std::array<double, 2> equirect_uv(Vec3 d);
Vec3 equirect_direction(double u, double v);
// World -> environment (the inverse of rotation_deg), as a 3x3 in a Mat4.
Mat4 environment_rotation(double rotation_deg);

// GL cube-map faces (+X, -X, +Y, -Y, +Z, -Z; GL 4.5 table 8.19): texel (s, t) in [0,1]^2 of
// face f looks along major + (2s - 1) s_axis + (2t - 1) t_axis; t = 0 is the first row.
struct CubeFace {
  Vec3 major, s_axis, t_axis;
};
const std::array<CubeFace, 6>& cube_faces();
Vec3 cube_direction(int face, double s, double t);  // normalised

// ---- Maps on the CPU ---------------------------------------------------------------------
// Equirectangular radiance, linear Rec.709 cd/m2 (before scale), 3 floats a pixel, rows top-down.
struct EnvironmentMap {
  int width = 0, height = 0;
  std::vector<float> rgb;
  Vec3 texel(int x, int y) const;
  // Bilinear, wrapping around in azimuth and clamped at the poles.
  Vec3 sample(Vec3 direction) const;
};

// The map's radiance averaged onto a coarse grid (area-weighted: integrals over the
// sphere are kept), with each cell's direction and solid angle: the quadrature behind the
// irradiance and the metering.
struct RadianceGrid {
  int width = 0, height = 0;
  std::vector<Vec3> radiance, direction;
  std::vector<double> solid_angle_sr;
};
RadianceGrid reduce_to_grid(const EnvironmentMap& map, int width = 128, int height = 64);
// E(n) = sum L cos+ dw over the grid, in lux (per unit scale).
Vec3 irradiance_lux(const RadianceGrid& grid, Vec3 normal);

// Irradiance E(n) for every texel of a small cube map: the renderer's diffuse light.
struct IrradianceCube {
  int size = 0;
  std::array<std::vector<Vec3>, 6> faces;  // texel (i, j) at faces[f][j * size + i]
  // Brightest irradiance over all directions (a card at the subject turned to the light).
  double max_illuminance_lux() const;
  Vec3 lookup(Vec3 direction) const;  // nearest texel
};
// 32 texels a face: bilinear filtering between texel centres 2.8 degrees apart stays
// within 0.3 % of the exact irradiance of smooth maps (16 would miss by 1.5 %).
IrradianceCube irradiance_cube(const RadianceGrid& grid, int size = 32);

// The sky's sun, in environment space (before rotation).
struct Sun {
  Vec3 direction;              // unit vector toward the sun
  Vec3 color{1, 1, 1};         // linear Rec.709, luminance 1
  double illuminance_lux = 0;  // at normal incidence, at the ground
  double angular_radius_rad = 0;
  double disc_luminance_nits = 0;  // illuminance / solid angle of the disc
};

// Everything the renderer derives from an environment on the CPU, once per source.
struct EnvironmentLighting {
  std::string description;      // "sky (elevation 45 deg, turbidity 2.5)" / file name
  EnvironmentMap map;           // background and the source of the specular maps (sky: without the disc)
  IrradianceCube irradiance;    // diffuse light (sky: without the sun, which is a light)
  double max_luminance_nits = 0;  // brightest texel of the map (the disc for the sky)
  std::optional<Sun> sun;       // the sky's sun
  std::vector<std::string> warnings;
};

// Loads an equirectangular OpenEXR or Radiance picture (told apart by their signatures)
// into linear Rec.709 cd/m2 before scale: EXR chromaticities / Radiance PRIMARIES and XYZE
// converted, EXR whiteLuminance applied, Radiance EXPOSURE divided out; NaN, Inf and
// negative values become 0 (with a warning that counts them).
Result<EnvironmentMap> load_environment_map(const std::filesystem::path& path, std::vector<std::string>& warnings,
                                           const io::InputFiles& files = {});
Result<EnvironmentLighting> build_environment(const EnvironmentSpec& spec);
// What identifies the CPU and GPU work of an environment (scale and rotation excluded:
// they apply per frame): file identity (path, size, modification time) or sky parameters.
std::string environment_cache_key(const EnvironmentSpec& spec);

}  // namespace hdrd::shading

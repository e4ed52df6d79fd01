#include "shading/sky.hpp"

#include <cmath>
#include <span>

#include "encode/colour/color.hpp"

namespace hdrd::shading {
namespace {

// Preetham et al. 1999, appendix A.2: Perez coefficients (A, B, C, D, E) = a T + b.
struct Linear {
  double a, b;
};
constexpr Linear kPerezY[5] = {{0.1787, -1.4630}, {-0.3554, 0.4275}, {-0.0227, 5.3251}, {0.1206, -2.5771},
                               {-0.0670, 0.3703}};
constexpr Linear kPerezX[5] = {{-0.0193, -0.2592}, {-0.0665, 0.0008}, {-0.0004, 0.2125}, {-0.0641, -0.8989},
                               {-0.0033, 0.0452}};
constexpr Linear kPerezYc[5] = {{-0.0167, -0.2608}, {-0.0950, 0.0092}, {-0.0079, 0.2102}, {-0.0441, -1.6537},
                                {-0.0109, 0.0529}};
// Zenith chromaticity: [T^2 T 1] M [theta_s^3 theta_s^2 theta_s 1]^T.
constexpr double kZenithX[3][4] = {
    {0.00166, -0.00375, 0.00209, 0}, {-0.02903, 0.06377, -0.03202, 0.00394}, {0.11693, -0.21196, 0.06052, 0.25886}};
constexpr double kZenithY[3][4] = {
    {0.00275, -0.00610, 0.00317, 0}, {-0.04214, 0.08970, -0.04153, 0.00516}, {0.15346, -0.26756, 0.06670, 0.26688}};

double perez(const std::array<double, 5>& k, double theta, double gamma) {
  const double cos_theta = std::max(std::cos(theta), 1e-6);
  const double cos_gamma = std::cos(gamma);
  return (1 + k[0] * std::exp(k[1] / cos_theta)) * (1 + k[2] * std::exp(k[3] * gamma) + k[4] * cos_gamma * cos_gamma);
}

double zenith_chromaticity(const double (&m)[3][4], double t, double theta_s) {
  const double tv[3] = {t * t, t, 1}, sv[4] = {theta_s * theta_s * theta_s, theta_s * theta_s, theta_s, 1};
  double sum = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) sum += tv[i] * m[i][j] * sv[j];
  return sum;
}

// ---- The sun (appendix A.2 and Iqbal 1983) ----------------------------------------------
// Extraterrestrial solar spectral radiance, W / (m^2 sr nm), 380..750 nm every 10 nm.
constexpr double kSolarRadiance[38] = {
    16559.0, 16233.7, 21127.5, 25888.2, 25829.1, 24232.3, 26760.5, 29658.3, 30545.4, 30057.5,
    30663.7, 28830.4, 28712.1, 27825.0, 27100.6, 27233.6, 26361.3, 25503.8, 25060.2, 25311.6,
    25355.9, 25134.2, 24631.5, 24173.2, 23685.3, 23212.1, 22827.7, 22339.8, 21970.2, 21526.7,
    21097.9, 20728.3, 20240.4, 19870.8, 19427.2, 19072.4, 18628.9, 18259.2};
constexpr double kSolarFirstNm = 380, kSolarStepNm = 10;

struct Sample {
  double nm, k;
};
// Ozone absorption coefficient k_o (1/cm), Iqbal p. 127.
constexpr Sample kOzone[] = {
    {300, 10.0},   {305, 4.8},    {310, 2.7},    {315, 1.35},   {320, 0.8},    {325, 0.380},  {330, 0.160},
    {335, 0.075},  {340, 0.04},   {345, 0.019},  {350, 0.007},  {355, 0.0},    {445, 0.003},  {450, 0.003},
    {455, 0.004},  {460, 0.006},  {465, 0.008},  {470, 0.009},  {475, 0.012},  {480, 0.014},  {485, 0.017},
    {490, 0.021},  {495, 0.025},  {500, 0.03},   {505, 0.035},  {510, 0.04},   {515, 0.045},  {520, 0.048},
    {525, 0.057},  {530, 0.063},  {535, 0.07},   {540, 0.075},  {545, 0.08},   {550, 0.085},  {555, 0.095},
    {560, 0.103},  {565, 0.110},  {570, 0.12},   {575, 0.122},  {580, 0.12},   {585, 0.118},  {590, 0.115},
    {595, 0.12},   {600, 0.125},  {605, 0.130},  {610, 0.12},   {620, 0.105},  {630, 0.09},   {640, 0.079},
    {650, 0.067},  {660, 0.057},  {670, 0.048},  {680, 0.036},  {690, 0.028},  {700, 0.023},  {710, 0.018},
    {720, 0.014},  {730, 0.011},  {740, 0.010},  {750, 0.009},  {760, 0.007},  {770, 0.004},  {780, 0.0},
    {790, 0.0}};
// Mixed gases k_g (1/km) and water vapour k_wa (1/cm), Iqbal p. 130.
constexpr Sample kGases[] = {{759, 0.0}, {760, 3.0}, {770, 0.210}, {771, 0.0}};
constexpr Sample kWater[] = {{689, 0.0},    {690, 0.016},  {700, 0.024},  {710, 0.0125}, {720, 1.0},
                             {730, 0.87},   {740, 0.061},  {750, 0.001},  {760, 0.00001}, {770, 0.00001},
                             {780, 0.0006}, {790, 0.0175}, {800, 0.036}};

double interpolate(std::span<const Sample> table, double nm) {
  if (nm <= table.front().nm) return table.front().k;
  for (std::size_t i = 1; i < table.size(); ++i)
    if (nm <= table[i].nm) {
      const double t = (nm - table[i - 1].nm) / (table[i].nm - table[i - 1].nm);
      return table[i - 1].k + t * (table[i].k - table[i - 1].k);
    }
  return table.back().k;
}

// Spectral transmittance of the atmosphere toward a sun at zenith angle theta.
double transmittance(double nm, double theta, double turbidity) {
  constexpr double kAlpha = 1.3, kOzoneCm = 0.35, kWaterCm = 2.0;
  const double theta_deg = theta * 180 / kPi;
  const double m = 1 / (std::cos(theta) + 0.15 * std::pow(93.885 - theta_deg, -1.253));  // Kasten 1966
  const double um = nm / 1000, beta = 0.04608 * turbidity - 0.04586;
  const double rayleigh = std::exp(-0.008735 * std::pow(um, -4.08) * m);
  const double aerosol = std::exp(-beta * std::pow(um, -kAlpha) * m);
  const double ozone = std::exp(-interpolate(kOzone, nm) * kOzoneCm * m);
  const double kg = interpolate(kGases, nm), kwa = interpolate(kWater, nm);
  const double gases = std::exp(-1.41 * kg * m / std::pow(1 + 118.93 * kg * m, 0.45));
  const double water = std::exp(-0.2385 * kwa * kWaterCm * m / std::pow(1 + 20.07 * kwa * kWaterCm * m, 0.45));
  return rayleigh * aerosol * ozone * gases * water;
}

double lobe(double x, double mean, double sigma_below, double sigma_above) {
  const double t = (x - mean) / (x < mean ? sigma_below : sigma_above);
  return std::exp(-0.5 * t * t);
}

}  // namespace

PreethamSky::PreethamSky(double turbidity, double sun_zenith_rad) {
  const double t = turbidity, theta_s = sun_zenith_rad;
  for (int i = 0; i < 5; ++i) {
    coeffs_[0][i] = kPerezX[i].a * t + kPerezX[i].b;
    coeffs_[1][i] = kPerezYc[i].a * t + kPerezYc[i].b;
    coeffs_[2][i] = kPerezY[i].a * t + kPerezY[i].b;
  }
  const double chi = (4.0 / 9.0 - t / 120.0) * (kPi - 2 * theta_s);
  zenith_ = {zenith_chromaticity(kZenithX, t, theta_s), zenith_chromaticity(kZenithY, t, theta_s),
             1000.0 * ((4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192)};
  for (int c = 0; c < 3; ++c) norm_[c] = perez(coeffs_[c], 0, theta_s);
}

std::array<double, 3> PreethamSky::xyY(double theta_rad, double gamma_rad) const {
  std::array<double, 3> out{};
  for (int c = 0; c < 3; ++c) out[c] = zenith_[c] * perez(coeffs_[c], theta_rad, gamma_rad) / norm_[c];
  return out;
}

Vec3 rec709_from_xyY(double x, double y, double luminance) {
  static const color::Mat3 kXyzToRec709 = color::xyz_to_rgb(color::kRec709);
  if (!(y > 0) || !(luminance > 0)) return {0, 0, 0};
  const color::Vec3 rgb = kXyzToRec709 * color::Vec3{x * luminance / y, luminance, (1 - x - y) * luminance / y};
  return {rgb.x, rgb.y, rgb.z};
}

std::array<double, 3> cie1931_xyz_bar(double nm) {
  return {1.056 * lobe(nm, 599.8, 37.9, 31.0) + 0.362 * lobe(nm, 442.0, 16.0, 26.7) - 0.065 * lobe(nm, 501.1, 20.4, 26.2),
          0.821 * lobe(nm, 568.8, 46.9, 40.5) + 0.286 * lobe(nm, 530.9, 16.3, 31.1),
          1.217 * lobe(nm, 437.0, 11.8, 36.0) + 0.681 * lobe(nm, 459.0, 26.0, 13.8)};
}

double sun_angular_radius_rad() {
  constexpr double kSolarRadiusM = 6.957e8, kAuM = 1.495978707e11;  // IAU 2015 B3, IAU 2012 B2
  return std::asin(kSolarRadiusM / kAuM);
}

Sun preetham_sun(const SkyParams& sky) {
  const double theta = (90 - sky.sun_elevation_deg) * kPi / 180;
  std::array<double, 3> xyz{};
  for (int i = 0; i < 38; ++i) {
    const double nm = kSolarFirstNm + kSolarStepNm * i;
    const double radiance = kSolarRadiance[i] * transmittance(nm, theta, sky.turbidity);
    const auto bar = cie1931_xyz_bar(nm);
    for (int c = 0; c < 3; ++c) xyz[c] += 683.0 * radiance * bar[c] * kSolarStepNm;  // cd/m2
  }
  Sun s;
  s.direction = direction_from_angles(0, sky.sun_elevation_deg * kPi / 180);
  s.angular_radius_rad = sun_angular_radius_rad();
  const double solid_angle = 2 * kPi * (1 - std::cos(s.angular_radius_rad));
  s.disc_luminance_nits = xyz[1];
  s.illuminance_lux = xyz[1] * solid_angle;
  const double sum = xyz[0] + xyz[1] + xyz[2];
  const Vec3 rgb = rec709_from_xyY(xyz[0] / sum, xyz[1] / sum, 1.0);
  s.color = vmax(rgb, Vec3{0, 0, 0}) / std::max(luminance(vmax(rgb, Vec3{0, 0, 0})), 1e-12);
  return s;
}

EnvironmentMap make_sky_map(const SkyParams& sky, int width, int height) {
  const double theta_s = (90 - sky.sun_elevation_deg) * kPi / 180;
  const PreethamSky model(sky.turbidity, theta_s);
  const Vec3 to_sun = direction_from_angles(0, sky.sun_elevation_deg * kPi / 180);
  EnvironmentMap m;
  m.width = width;
  m.height = height;
  m.rgb.assign(static_cast<std::size_t>(width) * height * 3, 0.0f);
  const int horizon = height / 2;  // rows [0, horizon) are sky, the rest ground (height is even)
  // The sky at azimuth 0 is symmetric about the sun's vertical plane: texel x mirrors
  // texel width - 1 - x, so half the row is evaluated. Horizontal illuminance by the same
  // quadrature as the irradiance (solid angle of each row of texels).
  Vec3 sky_lux{0, 0, 0};
  for (int y = 0; y < horizon; ++y) {
    const double v = (y + 0.5) / height, theta = v * kPi;
    const double row_solid_angle = (std::cos(double(y) / height * kPi) - std::cos(double(y + 1) / height * kPi)) * 2 * kPi / width;
    for (int x = width / 2; x < width; ++x) {
      const Vec3 d = equirect_direction((x + 0.5) / width, v);
      const double gamma = std::acos(std::clamp(dot(d, to_sun), -1.0, 1.0));
      const auto c = model.xyY(theta, gamma);
      const Vec3 rgb = vmax(rec709_from_xyY(c[0], c[1], c[2]), Vec3{0, 0, 0});
      for (int xx : {x, width - 1 - x}) {
        float* p = m.rgb.data() + (static_cast<std::size_t>(y) * width + xx) * 3;
        p[0] = float(rgb.x);
        p[1] = float(rgb.y);
        p[2] = float(rgb.z);
      }
      sky_lux = sky_lux + rgb * (2 * row_solid_angle * std::cos(theta));
    }
  }
  Vec3 ground_lux = sky_lux;
  if (sky.sun) {
    const Sun sun = preetham_sun(sky);
    ground_lux = ground_lux + sun.color * (sun.illuminance_lux * std::sin(sky.sun_elevation_deg * kPi / 180));
  }
  const Vec3 ground = ground_lux * (sky.ground_albedo / kPi);
  for (int y = horizon; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      float* p = m.rgb.data() + (static_cast<std::size_t>(y) * width + x) * 3;
      p[0] = float(ground.x);
      p[1] = float(ground.y);
      p[2] = float(ground.z);
    }
  return m;
}

}  // namespace hdrd::shading

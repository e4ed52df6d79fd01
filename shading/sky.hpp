// The built-in analytic daylight: A. J. Preetham, P. Shirley, B. Smits, "A Practical
// Analytic Model for Daylight", SIGGRAPH 1999.
// * Sky: the Perez et al. (1993) distribution F(theta, gamma) = (1 + A e^(B / cos theta))
//   (1 + C e^(D gamma) + E cos^2 gamma) for luminance Y and chromaticity x, y, with the
//   paper's coefficients linear in turbidity T (its table in §3.1 / appendix A.2) and its
//   zenith values: Y_z = (4.0453 T - 4.9710) tan chi - 0.2155 T + 2.4192 kcd/m2,
//   chi = (4/9 - T/120)(pi - 2 theta_s), x_z and y_z as cubic polynomials in theta_s.
// * Sun: the extraterrestrial solar spectral radiance, attenuated along the relative
//   optical air mass (Kasten 1966) by Rayleigh scattering, aerosols (Angstrom, with
//   beta = 0.04608 T - 0.04586, alpha = 1.3), ozone (0.35 cm), mixed gases and water vapour
//   (2 cm): the paper's appendix A.2, with the absorption tables it takes from Iqbal,
//   "An Introduction to Solar Radiation" (1983). The spectrum becomes CIE XYZ through the
//   multi-lobe fit of the CIE 1931 2 degree colour matching functions by Wyman, Sloan and
//   Shirley (JCGT 2(2), 2013), times 683 lm/W.
#pragma once

#include <array>

#include "shading/environment.hpp"

namespace hdrd::shading {

class PreethamSky {
 public:
  PreethamSky(double turbidity, double sun_zenith_rad);
  // CIE x, y and luminance Y (cd/m2) of the sky at zenith angle theta, angle gamma from
  // the sun (theta < pi/2).
  std::array<double, 3> xyY(double theta_rad, double gamma_rad) const;
  double zenith_luminance_nits() const { return zenith_[2]; }

 private:
  std::array<std::array<double, 5>, 3> coeffs_{};  // A..E for x, y, Y
  std::array<double, 3> zenith_{};                 // x_z, y_z, Y_z (cd/m2)
  std::array<double, 3> norm_{};                   // F(0, theta_s) for x, y, Y
};

// Linear Rec.709 of CIE xyY.
Vec3 rec709_from_xyY(double x, double y, double luminance);

// Mean angular radius of the sun seen from the Earth (IAU solar radius / 1 au).
double sun_angular_radius_rad();
// The sun at the ground for a sun at `sun_zenith_rad` (< pi/2 + a little: the air mass
// formula is finite at the horizon), in environment space with azimuth 0.
Sun preetham_sun(const SkyParams& sky);
// CIE 1931 XYZ colour matching functions (Wyman, Sloan & Shirley 2013, multi-lobe fit).
std::array<double, 3> cie1931_xyz_bar(double lambda_nm);

// The sky as an equirectangular map with the sun at azimuth 0 (the renderer turns it to
// sun_azimuth_deg), without the sun disc; below the horizon a Lambertian ground of
// radiance albedo (E_sky + E_sun sin(elevation)) / pi.
EnvironmentMap make_sky_map(const SkyParams& sky, int width = 1024, int height = 512);

}  // namespace hdrd::shading

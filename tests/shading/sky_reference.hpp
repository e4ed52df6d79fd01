// Preetham, Shirley & Smits 1999 (appendix A.2), written again from the paper for the
// tests: the model's horizontal sky illuminance by a fine quadrature, independent of
// shading/sky.cpp's map and of the renderer's irradiance.
#pragma once

#include <algorithm>
#include <cmath>

#include "shading/math.hpp"

namespace hdrd::shading::testing {

inline double preetham_horizontal_lux(double turbidity, double elevation_deg) {
  const double t = turbidity, ts = (90 - elevation_deg) * kPi / 180;
  const double A = 0.1787 * t - 1.4630, B = -0.3554 * t + 0.4275, C = -0.0227 * t + 5.3251, D = 0.1206 * t - 2.5771,
               E = -0.0670 * t + 0.3703;
  const auto F = [&](double theta, double gamma) {
    return (1 + A * std::exp(B / std::cos(theta))) * (1 + C * std::exp(D * gamma) + E * std::cos(gamma) * std::cos(gamma));
  };
  const double chi = (4.0 / 9 - t / 120) * (kPi - 2 * ts);
  const double yz = 1000 * ((4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192);  // kcd/m2 -> cd/m2
  const Vec3 sun{0, std::cos(ts), -std::sin(ts)};
  double sum = 0;
  const int nt = 400, np = 800;
  for (int i = 0; i < nt; ++i) {
    const double theta = (i + 0.5) / nt * kPi / 2;
    for (int j = 0; j < np; ++j) {
      const double phi = (j + 0.5) / np * 2 * kPi;
      const Vec3 d{std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
      const double gamma = std::acos(std::clamp(dot(d, sun), -1.0, 1.0));
      sum += yz * F(theta, gamma) / F(0, ts) * std::cos(theta) * std::sin(theta);
    }
  }
  return sum * (kPi / 2 / nt) * (2 * kPi / np);
}

}  // namespace hdrd::shading::testing

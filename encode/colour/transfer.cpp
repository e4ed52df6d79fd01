#include "encode/colour/transfer.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace hdrd::transfer {

double pq_inverse_eotf(double nits) {
  const double y = std::max(nits, 0.0) / kPqPeakNits;
  const double ym1 = std::pow(y, kPqM1);
  return std::pow((kPqC1 + kPqC2 * ym1) / (1.0 + kPqC3 * ym1), kPqM2);
}

double pq_eotf(double signal) {
  const double e = std::pow(std::clamp(signal, 0.0, 1.0), 1.0 / kPqM2);
  const double num = std::max(e - kPqC1, 0.0);
  return kPqPeakNits * std::pow(num / (kPqC2 - kPqC3 * e), 1.0 / kPqM1);
}

namespace {
// PQ as a function of log2(nits / 10000) on [-32, 0]: smooth, so linear
// interpolation on a 1/128-stop grid stays far below a 12-bit code.
constexpr int kFastSteps = 4096;
constexpr double kFastMinLog2 = -32.0;
const std::array<double, kFastSteps + 2>& fast_table() {
  static const auto table = [] {
    std::array<double, kFastSteps + 2> t{};
    for (int i = 0; i <= kFastSteps + 1; ++i)
      t[i] = pq_inverse_eotf(kPqPeakNits * std::exp2(kFastMinLog2 * (1.0 - double(i) / kFastSteps)));
    return t;
  }();
  return table;
}
}  // namespace

double pq_inverse_eotf_fast(double nits) {
  const double y = nits / kPqPeakNits;
  if (!(y > std::exp2(kFastMinLog2))) return pq_inverse_eotf(nits);
  if (y >= 1.0) return pq_inverse_eotf(nits);
  const double pos = (std::log2(y) - kFastMinLog2) * (kFastSteps / -kFastMinLog2);
  const int i = static_cast<int>(pos);
  const double f = pos - i;
  const auto& t = fast_table();
  return t[i] + (t[i + 1] - t[i]) * f;
}

// ---- HLG ------------------------------------------------------------------------------
double hlg_oetf(double e) {
  e = std::max(e, 0.0);
  return e <= 1.0 / 12.0 ? std::sqrt(3.0 * e) : kHlgA * std::log(12.0 * e - kHlgB) + kHlgC;
}

double hlg_inverse_oetf(double s) {
  s = std::max(s, 0.0);
  return s <= 0.5 ? s * s / 3.0 : (std::exp((s - kHlgC) / kHlgA) + kHlgB) / 12.0;
}

double hlg_system_gamma(double peak_nits) {
  if (peak_nits >= kHlgGammaRangeLowNits && peak_nits <= kHlgGammaRangeHighNits)
    return 1.2 + 0.42 * std::log10(peak_nits / 1000.0);
  return 1.2 * std::pow(kHlgExtendedGammaKappa, std::log2(peak_nits / 1000.0));
}

HlgDisplay HlgDisplay::from_levels(double peak_nits, double black_nits) {
  HlgDisplay d;
  d.peak_nits = peak_nits;
  d.black_nits = std::max(black_nits, 0.0);
  d.gamma = hlg_system_gamma(peak_nits);
  d.beta = std::sqrt(3.0 * std::pow(d.black_nits / peak_nits, 1.0 / d.gamma));
  return d;
}

double HlgDisplay::scene_of_signal(double signal) const {
  return hlg_inverse_oetf(std::max(0.0, (1.0 - beta) * signal + beta));
}

double HlgDisplay::signal_of_scene(double scene) const {
  const double lifted = hlg_oetf(std::clamp(scene, 0.0, 1.0));
  return beta > 0 ? std::clamp((lifted - beta) / (1.0 - beta), 0.0, 1.0) : lifted;
}

color::Vec3 HlgDisplay::ootf(color::Vec3 e) const {
  const double ys = color::dot(color::kRec2020Luma, e);
  return ys > 0 ? e * (peak_nits * std::pow(ys, gamma - 1.0)) : color::Vec3{};
}

double HlgDisplay::ootf_inverse_scale(double yd) const {
  // Fd = Lw Ys^(g-1) E and Yd = Lw Ys^g, so E = Fd / Lw * (Yd / Lw)^((1 - g) / g).
  return yd > 0 ? std::pow(yd / peak_nits, (1.0 - gamma) / gamma) / peak_nits : 0.0;
}

color::Vec3 HlgDisplay::inverse_ootf(color::Vec3 nits) const {
  const color::Vec3 fd{std::max(nits.x, 0.0), std::max(nits.y, 0.0), std::max(nits.z, 0.0)};
  return fd * ootf_inverse_scale(color::dot(color::kRec2020Luma, fd));
}

color::Vec3 HlgDisplay::eotf(color::Vec3 s) const {
  return ootf({scene_of_signal(s.x), scene_of_signal(s.y), scene_of_signal(s.z)});
}

color::Vec3 HlgDisplay::inverse_eotf(color::Vec3 nits) const {
  const color::Vec3 e = inverse_ootf(nits);
  return {signal_of_scene(e.x), signal_of_scene(e.y), signal_of_scene(e.z)};
}

color::Vec3 hlg_eotf(color::Vec3 signal, double peak_nits, double black_nits) {
  return HlgDisplay::from_levels(peak_nits, black_nits).eotf(signal);
}

color::Vec3 hlg_inverse_eotf(color::Vec3 nits, double peak_nits, double black_nits) {
  return HlgDisplay::from_levels(peak_nits, black_nits).inverse_eotf(nits);
}

// ---- sRGB / gamma 2.2 -----------------------------------------------------------------
double srgb_inverse_eotf(double l) {
  if (l <= 0.0031308) return 12.92 * std::max(l, 0.0);
  return 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
}

double srgb_eotf(double v) {
  if (v <= 0.04045) return std::max(v, 0.0) / 12.92;
  return std::pow((v + 0.055) / 1.055, 2.4);
}

double gamma22_inverse_eotf(double l) { return std::pow(std::max(l, 0.0), 1.0 / 2.2); }
double gamma22_eotf(double v) { return std::pow(std::max(v, 0.0), 2.2); }

// ---- BT.1886 --------------------------------------------------------------------------
Bt1886 Bt1886::from_levels(double white_nits, double black_nits) {
  const double w = std::pow(white_nits, 1.0 / 2.4);
  const double k = std::pow(std::max(black_nits, 0.0), 1.0 / 2.4);
  return {std::pow(w - k, 2.4), k / (w - k)};
}

double Bt1886::eotf(double v) const { return a * std::pow(std::max(v + b, 0.0), 2.4); }

double Bt1886::inverse_eotf(double nits) const {
  const double v = std::pow(std::max(nits, 0.0) / a, 1.0 / 2.4) - b;
  return std::clamp(v, 0.0, 1.0);
}

// ---- Quantisation ---------------------------------------------------------------------
int quantize_full(double s, int bits) {
  const double maxc = std::ldexp(1.0, bits) - 1.0;
  return static_cast<int>(std::lround(std::clamp(s, 0.0, 1.0) * maxc));
}

int quantize_narrow(double s, int bits) {
  const double v = (219.0 * std::clamp(s, 0.0, 1.0) + 16.0) * std::ldexp(1.0, bits - 8);
  return static_cast<int>(std::lround(v));
}

double dequantize_full(int code, int bits) { return code / (std::ldexp(1.0, bits) - 1.0); }
double dequantize_narrow(int code, int bits) {
  return (code / std::ldexp(1.0, bits - 8) - 16.0) / 219.0;
}

}  // namespace hdrd::transfer

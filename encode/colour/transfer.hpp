// Transfer functions (REFERENCE.md §2). Naming follows the standards: an EOTF maps a
// signal E' in [0,1] to display light; its inverse maps light to a signal. Functions
// taking or returning absolute light say `nits` (cd/m2) in the parameter name.
#pragma once

#include <cmath>

#include "encode/colour/color.hpp"

namespace hdrd::transfer {

// ---- PQ, SMPTE ST 2084 ---------------------------------------------------------------
inline constexpr double kPqM1 = 2610.0 / 16384.0;
inline constexpr double kPqM2 = 2523.0 / 4096.0 * 128.0;
inline constexpr double kPqC1 = 3424.0 / 4096.0;
inline constexpr double kPqC2 = 2413.0 / 4096.0 * 32.0;
inline constexpr double kPqC3 = 2392.0 / 4096.0 * 32.0;
inline constexpr double kPqPeakNits = 10000.0;

// E' = ((c1 + c2 Y^m1) / (1 + c3 Y^m1))^m2, Y = nits / 10000. Negative input -> PQ(0).
double pq_inverse_eotf(double nits);
// nits = 10000 * (max(E'^(1/m2) - c1, 0) / (c2 - c3 E'^(1/m2)))^(1/m1)
double pq_eotf(double signal);
// Cheap approximation (a rational fit in sqrt-log domain is overkill; this is a
// 2nd-order interpolation in a 1024-entry log2 table). Max abs error in E' over
// [0.0001, 10000] nits is stated in kPqFastMaxError and checked by a test.
double pq_inverse_eotf_fast(double nits);
inline constexpr double kPqFastMaxError = 2e-6;

// ---- HLG, BT.2100 --------------------------------------------------------------------
inline constexpr double kHlgA = 0.17883277;
inline constexpr double kHlgB = 1.0 - 4.0 * kHlgA;                 // 0.28466892
inline constexpr double kHlgC = 0.55991073;  // as published in BT.2100 (0.5 - a ln(4a), rounded)

double hlg_oetf(double scene_linear);          // E in [0,1] -> E'
double hlg_inverse_oetf(double signal);        // E' -> E in [0,1]

// System gamma of an HLG display of nominal peak Lw (BT.2100-2 Table 5 note 5f):
// gamma = 1.2 + 0.42 log10(Lw / 1000) over the usual production range 400 <= Lw <= 2000
// cd/m2, and outside it BT.2100's extended range formula gamma = 1.2 kappa^log2(Lw / 1000),
// kappa = 1.111 (BT.2390 §6.2 gives the same model, there with a surround term that hdrd
// keeps at its 5 cd/m2 reference). 1000 -> 1.2, 2000 -> 1.3264, 4000 -> 1.4812, 10000 -> 1.7023.
inline constexpr double kHlgGammaRangeLowNits = 400.0, kHlgGammaRangeHighNits = 2000.0;
inline constexpr double kHlgExtendedGammaKappa = 1.111;
double hlg_system_gamma(double peak_nits);

// An HLG display (BT.2100 Table 5): nominal peak Lw, black level Lb, the system gamma of
// Lw, and the black lift beta = sqrt(3 (Lb / Lw)^(1 / gamma)) of its EOTF
//   F_D = OOTF[OETF^-1[max(0, (1 - beta) E' + beta)]],  OOTF: F_D = Lw Y_S^(gamma - 1) E.
// beta is 0 for Lb = 0, where this is the plain BT.2100 EOTF.
struct HlgDisplay {
  double peak_nits = 1000, black_nits = 0;
  double gamma = 1.2, beta = 0;
  static HlgDisplay from_levels(double peak_nits, double black_nits);

  // Scene light of one channel for a code's signal E' (lift and inverse OETF), and the
  // signal of one channel's scene light E (E clipped to [0, 1] first; light below the
  // lifted black, E < OETF^-1(beta), has no signal and gets E' = 0).
  double scene_of_signal(double signal) const;
  double signal_of_scene(double scene) const;
  // The scene light E' = 0 decodes to, OETF^-1(beta) = (Lb / Lw)^(1 / gamma): the display's
  // black is this in every channel.
  double scene_black() const { return hlg_inverse_oetf(beta); }
  // OOTF and its inverse (BT.2100 Table 5). The inverse multiplies F_D by
  // (Y_D / Lw)^((1 - gamma) / gamma) / Lw, a factor of the luminance Y_D alone
  // (ootf_inverse_scale): that is what makes the displayable volume of a hue a simple
  // line, which the encoder's HLG volume mapping uses.
  color::Vec3 ootf(color::Vec3 scene) const;
  double ootf_inverse_scale(double luminance_nits) const;
  color::Vec3 inverse_ootf(color::Vec3 nits) const;  // unclamped: E may leave [0, 1]
  color::Vec3 eotf(color::Vec3 signal) const;
  color::Vec3 inverse_eotf(color::Vec3 nits) const;  // E clipped to [0, 1] per channel
};

// Display EOTF for an RGB signal at the display's peak and black (HlgDisplay::eotf).
color::Vec3 hlg_eotf(color::Vec3 signal, double peak_nits, double black_nits = 0);
// Inverse: display light (Rec.2020 nits) -> signal. Inverse OOTF, then the OETF and the
// inverse of the black lift.
color::Vec3 hlg_inverse_eotf(color::Vec3 nits, double peak_nits, double black_nits = 0);

// ---- sRGB, IEC 61966-2-1 -------------------------------------------------------------
double srgb_inverse_eotf(double linear);       // linear [0,1] -> V (piecewise)
double srgb_eotf(double signal);               // V -> linear

// ---- Pure gamma 2.2 (displays that decode sRGB content with a power law) -------------
double gamma22_inverse_eotf(double linear);
double gamma22_eotf(double signal);

// ---- BT.1886 -------------------------------------------------------------------------
// L = a * max(V + b, 0)^2.4, a = (Lw^(1/2.4) - Lb^(1/2.4))^2.4, b = Lb^(1/2.4) / (Lw^(1/2.4) - Lb^(1/2.4)).
struct Bt1886 {
  double a = 0, b = 0;
  static Bt1886 from_levels(double white_nits, double black_nits);
  double eotf(double signal) const;            // V -> nits
  double inverse_eotf(double nits) const;      // nits -> V, clipped to [0,1]
};

// ---- scRGB ---------------------------------------------------------------------------
inline constexpr double kScrgbUnitNits = 80.0;  // 1.0 = 80 cd/m2

// ---- Code values ---------------------------------------------------------------------
// Full range: D = round(E' (2^n - 1)). Narrow (BT.2100 table 9): D = round((219 E' + 16) 2^(n-8)).
int quantize_full(double signal, int bits);
int quantize_narrow(double signal, int bits);
double dequantize_full(int code, int bits);
double dequantize_narrow(int code, int bits);

}  // namespace hdrd::transfer

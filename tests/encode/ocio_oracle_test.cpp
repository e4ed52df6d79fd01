// OpenColorIO 2.1's built-in transforms as a second oracle for PQ and Rec.2100 (PQ and
// HLG). OCIO's scale: 1.0 = 100 cd/m2 (platform notes §3).
#include <gtest/gtest.h>

#include <OpenColorIO/OpenColorIO.h>

#include <random>

#include "encode/colour/color.hpp"
#include "encode/colour/transfer.hpp"

namespace OCIO = OCIO_NAMESPACE;
using namespace hdrd;
using color::Vec3;

namespace {

OCIO::ConstCPUProcessorRcPtr builtin(const char* style) {
  auto t = OCIO::BuiltinTransform::Create();
  t->setStyle(style);
  return OCIO::Config::CreateRaw()->getProcessor(t)->getDefaultCPUProcessor();
}

Vec3 apply(const OCIO::ConstCPUProcessorRcPtr& p, Vec3 v) {
  float px[3] = {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
  p->applyRGB(px);
  return {px[0], px[1], px[2]};
}

TEST(OcioOracle, St2084Curve) {
  const auto p = builtin("CURVE - LINEAR_to_ST-2084");
  for (double nits : {0.005, 0.1, 1.0, 26.0, 100.0, 203.0, 1000.0, 4000.0, 10000.0}) {
    const Vec3 o = apply(p, {nits / 100, nits / 100, nits / 100});
    EXPECT_NEAR(transfer::pq_inverse_eotf(nits), o.x, 1e-6) << nits;  // OCIO runs in float
  }
}

TEST(OcioOracle, Rec2100PqFromXyz) {
  const auto p = builtin("DISPLAY - CIE-XYZ-D65_to_REC.2100-PQ");
  const color::Mat3 xyz_to_2020 = color::xyz_to_rgb(color::kRec2020);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 8.0);
  for (int i = 0; i < 200; ++i) {
    // Colours inside Rec.2020: build them in RGB, go to XYZ for OCIO.
    const Vec3 rgb_nits{u(rng) * 100, u(rng) * 100, u(rng) * 100};
    const Vec3 xyz = color::rgb_to_xyz(color::kRec2020) * rgb_nits;
    const Vec3 o = apply(p, xyz * 0.01);
    const Vec3 ours = xyz_to_2020 * xyz;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(transfer::pq_inverse_eotf(ours[c]), o[c], 2e-5) << i;
  }
}

TEST(OcioOracle, Rec2100Hlg1000Nits) {
  const auto p = builtin("DISPLAY - CIE-XYZ-D65_to_REC.2100-HLG-1000nit");
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.01, 9.0);
  for (int i = 0; i < 200; ++i) {
    const Vec3 rgb_nits{u(rng) * 100, u(rng) * 100, u(rng) * 100};
    const Vec3 xyz = color::rgb_to_xyz(color::kRec2020) * rgb_nits;
    const Vec3 o = apply(p, xyz * 0.01);
    const Vec3 ours = transfer::hlg_inverse_eotf(rgb_nits, 1000);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(ours[c], o[c], 2e-4) << i << " ch " << c;
  }
}

}  // namespace

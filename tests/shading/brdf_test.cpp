// The CPU reference BRDF (shading/brdf.hpp) against properties and published values:
// energy (RTR4 eq. 9.8), reciprocity (eq. 9.7), GGX normalisation, a closed form, and
// the in-water F0 values of RTR4 table 9.4.
#include <gtest/gtest.h>

#include <random>

#include "shading/brdf.hpp"
#include "shading/materials.hpp"

namespace hdrd::shading {
namespace {

brdf::Lobes specular_only(double f0, double roughness) {
  brdf::Surface s;
  s.base_color = {f0, f0, f0};
  s.metallic = 1;  // F0 = base colour, rho = 0
  s.roughness = roughness;
  return brdf::resolve(s);
}

TEST(Brdf, SpecularAlbedoNeverExceedsOne) {
  // Eq. 9.8 over a grid of roughness, F0 and view angles.
  for (double r = 0; r <= 1.0001; r += 0.1)
    for (double f0 : {0.02, 0.04, 0.2, 0.5, 0.9, 1.0})
      for (double nv : {0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0}) {
        const Vec3 a = brdf::directional_albedo(specular_only(f0, r), nv, 2048);
        EXPECT_LE(a.x, 1.0 + 1e-3) << "roughness " << r << " F0 " << f0 << " n.v " << nv;
        EXPECT_GT(a.x, 0.0);
      }
}

TEST(Brdf, LambertWhiteAlbedoIsOne) {
  brdf::Surface s;
  s.base_color = {1, 1, 1};
  s.dielectric_f0 = 0;
  s.f90 = 0;  // no specular lobe at all: pure Lambert rho/pi
  for (double nv : {0.05, 0.3, 0.7, 1.0}) {
    const Vec3 a = brdf::directional_albedo(brdf::resolve(s), nv, 1024);
    EXPECT_NEAR(a.x, 1.0, 1e-3) << "n.v " << nv;
  }
}

TEST(Brdf, SmoothMirrorKeepsNearlyAllEnergy) {
  for (double r : {0.0, 0.1, 0.2, 0.3})
    for (double nv : {0.5, 0.6, 0.8, 1.0}) {
      const Vec3 a = brdf::directional_albedo(specular_only(1.0, r), nv, 8192);
      EXPECT_GE(a.x, 0.97) << "roughness " << r << " n.v " << nv;
    }
}

TEST(Brdf, RoughGgxAtNormalViewMatchesClosedForm) {
  // alpha = 1: D = 1/pi and, at n.v = 1, G2 = 2 n.l / (n.l + 1), so R = 1 - ln 2
  // (worked by hand from Heitz 2014's Lambda for GGX). Shows the single-scattering loss.
  const Vec3 a = brdf::directional_albedo(specular_only(1.0, 1.0), 1.0, 16384);
  EXPECT_NEAR(a.x, 1.0 - std::log(2.0), 2e-3);
}

TEST(Brdf, GgxDistributionIsNormalised) {
  // The projected microfacet area integrates to one: integral D(h) (n.h) dh = 1.
  for (double alpha : {0.05, 0.2, 0.5, 1.0}) {
    double sum = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      const double c = (i + 0.5) / n;  // cos(theta_h), uniform: d(omega) = 2 pi d(cos)
      sum += brdf::ggx_d(c, alpha) * c * 2 * kPi / n;
    }
    EXPECT_NEAR(sum, 1.0, 2e-3) << "alpha " << alpha;
  }
}

TEST(Brdf, Reciprocity) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const Vec3 n{0, 0, 1};
  for (int i = 0; i < 500; ++i) {
    brdf::Surface s;
    s.base_color = {0.2 + 0.3 * std::abs(u(rng)), 0.5, 0.9};
    s.metallic = std::abs(u(rng));
    s.roughness = std::abs(u(rng));
    const brdf::Lobes lobes = brdf::resolve(s);
    const Vec3 l = normalize({u(rng), u(rng), 0.05 + std::abs(u(rng))});
    const Vec3 v = normalize({u(rng), u(rng), 0.05 + std::abs(u(rng))});
    const Vec3 a = brdf::evaluate(lobes, n, l, v), b = brdf::evaluate(lobes, n, v, l);
    for (int c = 0; c < 3; ++c)  // only the 1e-5 n.v bias (Frostbite) breaks exact symmetry
      EXPECT_NEAR(a[c], b[c], 1e-3 * std::max(a[c], 1e-9)) << "sample " << i;
  }
}

TEST(Brdf, SchlickGeneralFormReducesToEq916) {
  for (double c : {0.0, 0.1, 0.5, 0.9, 1.0}) {
    const Vec3 f = brdf::schlick({0.04, 0.5, 1.0}, 1.0, 5.0, c);
    EXPECT_DOUBLE_EQ(f.x, 0.04 + 0.96 * std::pow(1 - c, 5));
    EXPECT_DOUBLE_EQ(f.y, 0.5 + 0.5 * std::pow(1 - c, 5));
    EXPECT_DOUBLE_EQ(f.z, 1.0);
  }
  // Eq. 9.18: F90 and the exponent 1/p.
  EXPECT_DOUBLE_EQ(brdf::schlick({0.1, 0.1, 0.1}, 0.5, 2.0, 0.5).x, 0.1 + 0.4 * 0.25);
}

TEST(Brdf, SpecularCutoffOnlyInAir) {
  brdf::Surface s;
  s.base_color = {0.5, 0.5, 0.5};
  s.dielectric_f0 = 0.0007;  // skin in water (table 9.4)
  EXPECT_NEAR(brdf::resolve(s).f90, 50 * 0.0007, 1e-12);  // in air the cut-off fades F90
  s.medium_ior = kWaterIor;
  EXPECT_DOUBLE_EQ(brdf::resolve(s).f90, 1.0);  // under water it must stay off
}

TEST(Brdf, GltfCouplingExceedsOneAtGrazingViewForWhiteBase) {
  // Documented limitation of f = (1 - F(v.h)) rho/pi + F D V: with rho = 1 the albedo is
  // about 1 at normal view but clearly above 1 at grazing view (docs/rendering.md).
  brdf::Surface s;
  s.base_color = {1, 1, 1};
  s.roughness = 0.5;
  EXPECT_NEAR(brdf::directional_albedo(brdf::resolve(s), 1.0, 8192).x, 1.0, 0.01);
  EXPECT_GT(brdf::directional_albedo(brdf::resolve(s), 0.05, 8192).x, 1.05);
}

TEST(Materials, WaterF0OfTable94Dielectrics) {
  // RTR4 table 9.4 (n1 = 1.33): in-air F0 -> in-water F0 through eq. 9.17 and 9.19.
  const struct { const char* name; double air, water; } rows[] = {
      {"skin", 0.028, 0.0007}, {"k7-glass", 0.042, 0.004}, {"diamond", 0.172, 0.084}};
  for (const auto& r : rows) {
    EXPECT_NEAR(dielectric_f0_in_medium(r.air, kWaterIor), r.water, 5e-4) << r.name;
    const F0Preset* p = find_f0_preset(r.name);
    ASSERT_NE(p, nullptr) << r.name;
    EXPECT_DOUBLE_EQ(p->f0_air.x, r.air);
    EXPECT_NEAR(dielectric_f0_in_medium(p->f0_air.x, kWaterIor), p->f0_water->x, 5e-4);
  }
  EXPECT_DOUBLE_EQ(dielectric_f0_in_medium(0.04, 1.0), 0.04);
}

TEST(Materials, MetalsInWaterFromTheTable) {
  for (const char* name : {"iron", "gold", "silver"}) {
    const F0Preset* p = find_f0_preset(name);
    ASSERT_TRUE(p && p->f0_water) << name;
    const Vec3 n = preset_metal_n(*p);
    const Vec3 w = metal_f0_in_medium(p->f0_air, n, kWaterIor);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(w[c], (*p->f0_water)[c], 1e-4) << name << " channel " << c;
      EXPECT_GT(n[c], 0.05);  // a physical real IOR
      EXPECT_LT(n[c], 5.0);
    }
    // Without the table (n = 1 assumed) the estimate stays within 0.035.
    const Vec3 guess = metal_f0_in_medium(p->f0_air, {1, 1, 1}, kWaterIor);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(guess[c], (*p->f0_water)[c], 0.035) << name;
  }
  EXPECT_EQ(metal_f0_in_medium({0.9, 0.5, 0.2}, {2, 2, 2}, 1.0), (Vec3{0.9, 0.5, 0.2}));
}

TEST(Materials, PresetTablesAsPublished) {
  // Spot checks of REFERENCE.md §5 (RTR4 tables 9.1 and 9.2).
  EXPECT_EQ(find_f0_preset("gold")->f0_air, (Vec3{1.000, 0.782, 0.344}));
  EXPECT_EQ(find_f0_preset("copper")->f0_air, (Vec3{0.955, 0.638, 0.538}));
  EXPECT_EQ(find_f0_preset("aluminum")->f0_air, (Vec3{0.913, 0.922, 0.924}));
  EXPECT_DOUBLE_EQ(find_f0_preset("water")->f0_air.x, 0.02);
  EXPECT_DOUBLE_EQ(find_f0_preset("gems")->f0_air_low, 0.05);
  EXPECT_DOUBLE_EQ(find_f0_preset("gems")->f0_air_high, 0.08);
  int metals = 0;
  for (const auto& p : f0_presets()) {
    metals += p.kind == PresetKind::metal;
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(p.f0_air[c], 0.0) << p.name;
      EXPECT_LE(p.f0_air[c], 1.0) << p.name;
    }
  }
  EXPECT_EQ(metals, 14);
  EXPECT_EQ(find_f0_preset("unobtainium"), nullptr);
}

TEST(Brdf, AmbientTermsOfAWhiteLambertAddUpToOne) {
  // With F0 = F90 = 0 the ambient term is rho ((1 - d1) + d1): exactly the environment.
  for (double nv : {0.0, 0.3, 1.0})
    for (double r : {0.0, 0.5, 1.0}) {
      const auto t = brdf::ambient_terms(nv, r, 256);
      EXPECT_GE(t.d1, 0.0);
      EXPECT_LE(t.d1, 1.0);
      EXPECT_LE(t.s0 + t.s1, 1.0 + 2e-3);
    }
}

}  // namespace
}  // namespace hdrd::shading

namespace hdrd::shading {
namespace {

TEST(Brdf, AmbientTableSpecularIsTheDirectionalAlbedoWithFOne) {
  // The split-sum table's s0 + s1 is E_ss, the quantity energy compensation divides by.
  for (double r : {0.1, 0.5, 1.0})
    for (double nv : {0.1, 0.5, 1.0}) {
      const auto t = brdf::ambient_terms(nv, r, 1024);
      EXPECT_NEAR(t.s0 + t.s1, brdf::single_scatter_albedo(nv, r, 4096), 3e-3) << "r " << r << " n.v " << nv;
    }
}

}  // namespace
}  // namespace hdrd::shading

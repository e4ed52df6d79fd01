// Environment maps on the CPU: the Radiance reader against stb_image and ffmpeg, the
// direction conventions against their definitions and GL's cube-map table, the
// irradiance quadrature against Monte Carlo, and the sky and sun against published
// values (CIE 1931 tables, daylight measurements).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>

#include "encode/io/io.hpp"
#include "shading/environment.hpp"
#include "shading/radiance_hdr.hpp"
#include "shading/scene_loader.hpp"
#include "shading/sky.hpp"
#include "tests/shading/sky_reference.hpp"
#include "tests/testing/testing.hpp"

#if __has_include(<stb/stb_image.h>)
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_HDR
#include <stb/stb_image.h>
#define HDRD_HAVE_STB 1
#endif

namespace hdrd::shading {
namespace {

std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

std::vector<std::uint8_t> radiance_file(const std::string& header, const std::string& resolution,
                                        const std::vector<std::uint8_t>& data) {
  auto out = bytes_of("#?RADIANCE\n" + header + "\n" + resolution + "\n");
  out.insert(out.end(), data.begin(), data.end());
  return out;
}

// Radiance's colr_color(), written from its definition: (m + 0.5) 2^(e - 136).
double rgbe_value(int m, int e) { return e == 0 ? 0.0 : std::ldexp(m + 0.5, e - 136); }

void write_bytes(const std::filesystem::path& p, const std::vector<std::uint8_t>& b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

TEST(RadianceHdr, FlatPixelsDecodeAsColrColor) {
  const std::vector<std::uint8_t> px = {128, 64, 32, 129, 10, 20, 30, 130, 0, 0, 0, 0, 255, 255, 255, 140, 1, 2, 3, 120, 200, 100, 50, 128};
  auto r = read_radiance_hdr_memory(radiance_file("FORMAT=32-bit_rle_rgbe\n", "-Y 2 +X 3", px));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->image.width, 3);
  ASSERT_EQ(r->image.height, 2);
  for (int i = 0; i < 6; ++i)
    for (int c = 0; c < 3; ++c)
      EXPECT_FLOAT_EQ(r->image.rgba[i * 4 + c], float(rgbe_value(px[i * 4 + c], px[i * 4 + 3]))) << i << "," << c;
}

TEST(RadianceHdr, EveryOrientationLandsTheSamePixelsTopDown) {
  // The same 3 wide x 2 high picture, pixel k = (k, 0, 0, 128 + 8), written in each order.
  const auto value = [](int x, int y) { return std::uint8_t(10 * (y * 3 + x) + 5); };
  struct Order {
    const char* res;
    bool scan_y, scan_from_top_or_left, pixel_forward;
  };
  for (const Order o : {Order{"-Y 2 +X 3", true, true, true}, Order{"+Y 2 +X 3", true, false, true},
                        Order{"-Y 2 -X 3", true, true, false}, Order{"+Y 2 -X 3", true, false, false},
                        Order{"+X 3 -Y 2", false, true, true}, Order{"+X 3 +Y 2", false, true, false},
                        Order{"-X 3 -Y 2", false, false, true}, Order{"-X 3 +Y 2", false, false, false}}) {
    std::vector<std::uint8_t> data;
    const int n1 = o.scan_y ? 2 : 3, n2 = o.scan_y ? 3 : 2;
    for (int i = 0; i < n1; ++i)
      for (int j = 0; j < n2; ++j) {
        const int a = o.scan_from_top_or_left ? i : n1 - 1 - i, b = o.pixel_forward ? j : n2 - 1 - j;
        const int x = o.scan_y ? b : a, y = o.scan_y ? a : b;  // y counted from the top
        data.insert(data.end(), {value(x, y), 0, 0, 136});
      }
    auto r = read_radiance_hdr_memory(radiance_file("", o.res, data));
    ASSERT_TRUE(r.ok()) << o.res << ": " << r.error().message;
    ASSERT_EQ(r->image.width, 3) << o.res;
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) EXPECT_FLOAT_EQ(r->image.px(x, y)[0], float(rgbe_value(value(x, y), 136))) << o.res;
  }
}

TEST(RadianceHdr, RunLengthsOldAndNew) {
  // New style: 8 pixels, planes coded as a run, literals, a run, a run.
  std::vector<std::uint8_t> line = {2, 2, 0, 8, 128 + 8, 77, 8, 1, 2, 3, 4, 5, 6, 7, 8, 128 + 8, 9, 128 + 8, 130};
  auto r = read_radiance_hdr_memory(radiance_file("", "-Y 1 +X 8", line));
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int x = 0; x < 8; ++x) {
    EXPECT_FLOAT_EQ(r->image.px(x, 0)[0], float(rgbe_value(77, 130)));
    EXPECT_FLOAT_EQ(r->image.px(x, 0)[1], float(rgbe_value(x + 1, 130)));
    EXPECT_FLOAT_EQ(r->image.px(x, 0)[2], float(rgbe_value(9, 130)));
  }
  // Old style: a pixel, then (1, 1, 1, 5) repeats it five times.
  r = read_radiance_hdr_memory(radiance_file("", "-Y 1 +X 7", {50, 60, 70, 128, 1, 1, 1, 5, 9, 9, 9, 129}));
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int x = 0; x < 6; ++x) EXPECT_FLOAT_EQ(r->image.px(x, 0)[1], float(rgbe_value(60, 128)));
  EXPECT_FLOAT_EQ(r->image.px(6, 0)[0], float(rgbe_value(9, 129)));
}

TEST(RadianceHdr, HeaderVariablesAreHonoured) {
  const std::vector<std::uint8_t> px = {100, 100, 100, 129};
  const double v = rgbe_value(100, 129);
  auto r = read_radiance_hdr_memory(radiance_file("EXPOSURE=2\nEXPOSURE=2\nCOLORCORR=1 2 4\n", "-Y 1 +X 1", px));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->exposure, 4);
  EXPECT_FLOAT_EQ(r->image.rgba[0], float(v / 4));
  EXPECT_FLOAT_EQ(r->image.rgba[1], float(v / 8));
  EXPECT_FLOAT_EQ(r->image.rgba[2], float(v / 16));
  r = read_radiance_hdr_memory(radiance_file("FORMAT=32-bit_rle_xyze\nPRIMARIES=0.64 0.33 0.29 0.6 0.15 0.06 0.3333 0.3333\n",
                                             "-Y 1 +X 1", px));
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->xyz);
  ASSERT_TRUE(r->primaries.has_value());
  EXPECT_DOUBLE_EQ(r->primaries->green.x, 0.29);
}

TEST(RadianceHdr, CorruptFilesAreClearErrors) {
  struct Bad {
    std::vector<std::uint8_t> bytes;
    const char* code;
  };
  const std::vector<Bad> cases = {
      {bytes_of("P6\n3 2\n255\n"), "hdr.signature"},
      {bytes_of("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n"), "hdr.truncated"},
      {radiance_file("FORMAT=16-bit_weird\n", "-Y 1 +X 1", {1, 2, 3, 4}), "hdr.format"},
      {radiance_file("EXPOSURE=-1\n", "-Y 1 +X 1", {1, 2, 3, 4}), "hdr.header"},
      {radiance_file("", "-Y 1 +Y 1", {1, 2, 3, 4}), "hdr.resolution"},
      {radiance_file("", "-Y 0 +X 4", {}), "hdr.size"},
      {radiance_file("", "-Y 100000 +X 4", {}), "hdr.size"},
      {radiance_file("", "-Y 2 +X 8", {2, 2, 0, 8, 200, 1}), "hdr.rle"},           // run of 72 in 8 pixels
      {radiance_file("", "-Y 2 +X 8", {2, 2, 0, 9, 136, 1}), "hdr.rle"},           // scanline length mismatch
      {radiance_file("", "-Y 1 +X 3", {1, 1, 1, 3, 0, 0, 0, 0}), "hdr.rle"},       // repeat with nothing before
      {radiance_file("", "-Y 1 +X 3", {1, 2, 3, 128, 1, 1, 1, 9}), "hdr.rle"},     // repeat past the end
      {radiance_file("", "-Y 8192 +X 16384", std::vector<std::uint8_t>(16)), "hdr.truncated"},
  };
  for (const Bad& b : cases) {
    auto r = read_radiance_hdr_memory(b.bytes);
    ASSERT_FALSE(r.ok()) << b.code;
    EXPECT_EQ(r.error().code, b.code) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
    EXPECT_FALSE(r.error().message.empty());
  }
}

#ifdef HDRD_HAVE_STB
// stb_image (Debian's libstb-dev) decodes value = m 2^(e - 136), without colr_color's
// half-step: ours may exceed it by exactly half a mantissa step.
void expect_matches_stb(const std::vector<std::uint8_t>& file) {
  int w = 0, h = 0, n = 0;
  float* ref = stbi_loadf_from_memory(file.data(), int(file.size()), &w, &h, &n, 3);
  ASSERT_NE(ref, nullptr) << stbi_failure_reason();
  auto r = read_radiance_hdr_memory(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->image.width, w);
  ASSERT_EQ(r->image.height, h);
  for (int i = 0; i < w * h; ++i) {
    const float* p = r->image.rgba.data() + i * 4;
    const double m = std::max({ref[i * 3], ref[i * 3 + 1], ref[i * 3 + 2]});
    // The shared exponent's half step is below 1/256 of the largest channel... or 1/128 of it.
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(p[c], ref[i * 3 + c]) << i;
      EXPECT_LE(p[c] - ref[i * 3 + c], m / 255.0 + 1e-37) << i;
    }
  }
  stbi_image_free(ref);
}

// New-style run-length coding of one scanline, from the format description: per plane,
// runs of >= 3 equal bytes as (128 + n, byte), everything else as literals (n, bytes...).
std::vector<std::uint8_t> rle_scanline(const std::uint8_t* px, int w) {
  std::vector<std::uint8_t> out = {2, 2, std::uint8_t(w >> 8), std::uint8_t(w & 0xff)};
  for (int c = 0; c < 4; ++c) {
    int j = 0;
    while (j < w) {
      int run = 1;
      while (j + run < w && run < 127 && px[(j + run) * 4 + c] == px[j * 4 + c]) ++run;
      if (run >= 3) {
        out.insert(out.end(), {std::uint8_t(128 + run), px[j * 4 + c]});
        j += run;
        continue;
      }
      int lit = 0;
      while (j + lit < w && lit < 128 &&
             !(j + lit + 2 < w && px[(j + lit) * 4 + c] == px[(j + lit + 1) * 4 + c] &&
               px[(j + lit) * 4 + c] == px[(j + lit + 2) * 4 + c]))
        ++lit;
      out.push_back(std::uint8_t(lit));
      for (int k = 0; k < lit; ++k) out.push_back(px[(j + k) * 4 + c]);
      j += lit;
    }
  }
  return out;
}

TEST(RadianceHdr, AgreesWithStbImageFlatAndRunLength) {
  std::mt19937 rng(7);
  const int w = 64, h = 9;
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w) * h * 4);
  for (std::size_t i = 0; i < px.size(); i += 4) {
    const bool flat_patch = (i / 4) % 16 < 6;  // runs for the encoder
    px[i + 3] = std::uint8_t(flat_patch ? 130 : 100 + rng() % 60);
    px[i] = std::uint8_t(flat_patch ? 200 : 128 + rng() % 128);  // the largest channel, normalised
    px[i + 1] = std::uint8_t(flat_patch ? 90 : rng() % 256);
    px[i + 2] = std::uint8_t(rng() % 8 == 0 ? px[i + 1] : rng() % 256);
  }
  const std::string res = "-Y " + std::to_string(h) + " +X " + std::to_string(w);
  expect_matches_stb(radiance_file("FORMAT=32-bit_rle_rgbe\n", res, px));
  std::vector<std::uint8_t> rle;
  for (int y = 0; y < h; ++y) {
    const auto line = rle_scanline(px.data() + static_cast<std::size_t>(y) * w * 4, w);
    rle.insert(rle.end(), line.begin(), line.end());
  }
  ASSERT_LT(rle.size(), px.size());
  expect_matches_stb(radiance_file("FORMAT=32-bit_rle_rgbe\n", res, rle));
}
#endif

TEST(RadianceHdr, AgreesWithOpenImageIo) {
  // OpenImageIO's Radiance writer (run-length scanlines) and reader as the reference.
  if (hdrd::testing::run_command("oiiotool --help >/dev/null 2>&1").exit_code != 0)
    GTEST_SKIP() << "oiiotool (Debian's openimageio-tools) is not installed";
  hdrd::testing::TempDir dir;
  const auto hdr = dir / "ramp.hdr", exr = dir / "ramp.exr";
  const auto run = hdrd::testing::run_command(
      "oiiotool --pattern fill:topleft=0.1,2,30:topright=500,0.3,0.01:bottomleft=1e-3,1e3,4:bottomright=7,7,7 96x48 3 "
      "-d float -o '" + hdr.string() + "' && oiiotool '" + hdr.string() + "' -d float -o '" + exr.string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto r = read_radiance_hdr(hdr);
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto ref = io::read_exr(exr);
  ASSERT_TRUE(ref.ok()) << ref.error().message;
  ASSERT_EQ(r->image.width, ref->image.width);
  ASSERT_EQ(r->image.height, ref->image.height);
  for (std::size_t i = 0; i < r->image.pixel_count(); ++i) {
    const float* a = r->image.rgba.data() + i * 4;
    const float* b = ref->image.rgba.data() + i * 4;
    const double m = std::max({b[0], b[1], b[2]});
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], m / 255.0 + 1e-30) << i;
  }
}

// ---- Conventions ------------------------------------------------------------------------

TEST(EnvironmentConventions, EquirectangularMapping) {
  struct Case {
    Vec3 d;
    double u, v;
  };
  // The documented convention: u = 0.5 + azimuth / 360 (azimuth from -z toward +x), v = zenith angle / 180.
  for (const Case& c : {Case{{0, 0, -1}, 0.5, 0.5}, Case{{1, 0, 0}, 0.75, 0.5}, Case{{-1, 0, 0}, 0.25, 0.5},
                        Case{{0, 1, 0}, 0.5, 0.0}, Case{{0, -1, 0}, 0.5, 1.0},
                        Case{{0, std::sqrt(0.5), -std::sqrt(0.5)}, 0.5, 0.25}}) {
    const auto uv = equirect_uv(c.d);
    EXPECT_NEAR(uv[0], c.u, 1e-12);
    EXPECT_NEAR(uv[1], c.v, 1e-12);
    const Vec3 back = equirect_direction(c.u, c.v);
    EXPECT_NEAR(length(back - c.d), 0, 1e-12);
  }
  const auto behind = equirect_uv({0, 0, 1});  // the seam
  EXPECT_TRUE(std::abs(behind[0]) < 1e-12 || std::abs(behind[0] - 1) < 1e-12);
}

TEST(EnvironmentConventions, RotationTurnsInTheSenseOfAzimuth) {
  // What the file shows at azimuth a appears at a + rotation: the world direction at
  // azimuth 90 (+x) looks up the file's azimuth 0 (-z) under a 90 degree rotation.
  const Mat4 r = environment_rotation(90);
  EXPECT_NEAR(length(r.transform_dir({1, 0, 0}) - Vec3{0, 0, -1}), 0, 1e-12);
  EXPECT_NEAR(length(r.transform_dir({0, 1, 0}) - Vec3{0, 1, 0}), 0, 1e-12);
  const Vec3 d = direction_from_angles(30 * kPi / 180, 10 * kPi / 180);
  const auto uv = equirect_uv(environment_rotation(25).transform_dir(d));
  EXPECT_NEAR(uv[0], 0.5 + 5.0 / 360, 1e-12);
}

TEST(EnvironmentConventions, CubeFacesFollowGlTable) {
  // GL 4.5 table 8.19, written out: the face is the major axis, s = (sc/|ma| + 1)/2,
  // t = (tc/|ma| + 1)/2. cube_direction must invert it.
  const auto select = [](Vec3 r, int& face, double& s, double& t) {
    const double ax = std::abs(r.x), ay = std::abs(r.y), az = std::abs(r.z);
    double sc, tc, ma;
    if (ax >= ay && ax >= az) {
      face = r.x > 0 ? 0 : 1, sc = r.x > 0 ? -r.z : r.z, tc = -r.y, ma = ax;
    } else if (ay >= az) {
      face = r.y > 0 ? 2 : 3, sc = r.x, tc = r.y > 0 ? r.z : -r.z, ma = ay;
    } else {
      face = r.z > 0 ? 4 : 5, sc = r.z > 0 ? r.x : -r.x, tc = -r.y, ma = az;
    }
    s = (sc / ma + 1) / 2;
    t = (tc / ma + 1) / 2;
  };
  for (int f = 0; f < 6; ++f)
    for (double s : {0.1, 0.5, 0.8})
      for (double t : {0.2, 0.5, 0.9}) {
        int face = -1;
        double s2 = 0, t2 = 0;
        select(cube_direction(f, s, t), face, s2, t2);
        EXPECT_EQ(face, f);
        EXPECT_NEAR(s2, s, 1e-12);
        EXPECT_NEAR(t2, t, 1e-12);
      }
}

// ---- Irradiance ---------------------------------------------------------------------------

EnvironmentMap analytic_map(int w, int h, Vec3 (*radiance)(Vec3)) {
  EnvironmentMap m;
  m.width = w;
  m.height = h;
  m.rgb.resize(static_cast<std::size_t>(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 c = radiance(equirect_direction((x + 0.5) / w, (y + 0.5) / h));
      float* p = m.rgb.data() + (static_cast<std::size_t>(y) * w + x) * 3;
      p[0] = float(c.x), p[1] = float(c.y), p[2] = float(c.z);
    }
  return m;
}

Vec3 studio(Vec3 d) {  // a bright soft window up and to the right over a dim gradient
  const double window = std::exp(-12 * (1 - dot(d, normalize(Vec3{0.6, 0.7, -0.3}))));
  return Vec3{200, 180, 160} * (1 + 0.5 * d.y) + Vec3{9000, 9500, 10000} * window;
}

// Monte Carlo irradiance with stratified (jittered) cosine-distributed directions,
// strata^2 samples: E = pi * mean(L). Stratifying keeps the noise near 0.1 %.
Vec3 monte_carlo_irradiance(const EnvironmentMap& m, Vec3 n, int strata) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u01(0, 1);
  const Vec3 t = normalize(cross(std::abs(n.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}, n)), b = cross(n, t);
  Vec3 sum{0, 0, 0};
  for (int i = 0; i < strata; ++i)
    for (int j = 0; j < strata; ++j) {
      const double r = std::sqrt((i + u01(rng)) / strata), phi = 2 * kPi * (j + u01(rng)) / strata;
      sum = sum + m.sample(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1 - r * r)));
    }
  return sum * (kPi / (strata * strata));
}

TEST(EnvironmentIrradiance, UniformMapGivesPiL) {
  const EnvironmentMap m = analytic_map(256, 128, [](Vec3) { return Vec3{1000, 1000, 1000}; });
  const IrradianceCube c = irradiance_cube(reduce_to_grid(m));
  for (const auto& face : c.faces)
    for (const Vec3& e : face) EXPECT_NEAR(e.y, kPi * 1000, kPi * 1000 * 2e-3);
  EXPECT_NEAR(c.max_illuminance_lux(), kPi * 1000, 2e-3 * kPi * 1000);
}

TEST(EnvironmentIrradiance, QuadratureMatchesMonteCarloWithin1Percent) {
  const EnvironmentMap m = analytic_map(512, 256, studio);
  const RadianceGrid g = reduce_to_grid(m);
  for (Vec3 n : {Vec3{0, 1, 0}, Vec3{0, -1, 0}, normalize(Vec3{0.6, 0.7, -0.3}), normalize(Vec3{-1, 0.2, 0.4}),
                 Vec3{0, 0, 1}}) {
    const Vec3 mc = monte_carlo_irradiance(m, n, 300), q = irradiance_lux(g, n);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(q[c], mc[c], 0.01 * mc[c]) << n.x << "," << n.y << "," << n.z;
  }
}

// ---- Sky and sun ---------------------------------------------------------------------------

TEST(Sky, ColourMatchingFitAgreesWithCie1931Table) {
  // CIE 15:2004 table T.4 (CIE 1931 2 degree observer).
  struct Row {
    double nm, x, y, z;
  };
  for (const Row& r : {Row{450, 0.33620, 0.03800, 1.77211}, Row{500, 0.00490, 0.32300, 0.27200},
                       Row{555, 0.51205, 1.00000, 0.00575}, Row{600, 1.06220, 0.63100, 0.00080},
                       Row{650, 0.28350, 0.10700, 0.00000}}) {
    const auto f = cie1931_xyz_bar(r.nm);
    EXPECT_NEAR(f[0], r.x, 0.03) << r.nm;
    EXPECT_NEAR(f[1], r.y, 0.03) << r.nm;
    EXPECT_NEAR(f[2], r.z, 0.04) << r.nm;
  }
}

TEST(Sky, SunMatchesPublishedDaylight) {
  SkyParams clear;
  clear.sun_elevation_deg = 90;
  clear.turbidity = 2;
  const Sun zenith = preetham_sun(clear);
  // The sun's mean luminance through a clear atmosphere is about 1.6e9 cd/m2 and its direct
  // normal illuminance about 100 klx (extraterrestrial: 128-134 klx; RTR4 and Darula et al. 2005).
  EXPECT_GT(zenith.disc_luminance_nits, 1.3e9);
  EXPECT_LT(zenith.disc_luminance_nits, 1.8e9);
  EXPECT_GT(zenith.illuminance_lux, 90e3);
  EXPECT_LT(zenith.illuminance_lux, 125e3);
  EXPECT_NEAR(zenith.angular_radius_rad * 180 / kPi, 0.2666, 0.001);  // 32' diameter
  EXPECT_NEAR(zenith.illuminance_lux,
              zenith.disc_luminance_nits * 2 * kPi * (1 - std::cos(zenith.angular_radius_rad)), 1e-6 * zenith.illuminance_lux);
  EXPECT_NEAR(luminance(zenith.color), 1.0, 1e-9);
  // Lower and hazier means dimmer and redder.
  double previous = zenith.illuminance_lux;
  for (double elevation : {60.0, 30.0, 10.0, 3.0}) {
    SkyParams s = clear;
    s.sun_elevation_deg = elevation;
    const Sun sun = preetham_sun(s);
    EXPECT_LT(sun.illuminance_lux, previous) << elevation;
    previous = sun.illuminance_lux;
    EXPECT_GT(sun.color.x / sun.color.z, zenith.color.x / zenith.color.z) << elevation;
  }
  SkyParams hazy = clear;
  hazy.turbidity = 6;
  EXPECT_LT(preetham_sun(hazy).illuminance_lux, 0.85 * zenith.illuminance_lux);
}

TEST(Sky, MapHorizontalIlluminanceMatchesTheModel) {
  for (double elevation : {15.0, 45.0, 75.0})
    for (double turbidity : {2.0, 4.0}) {
      SkyParams p;
      p.sun_elevation_deg = elevation;
      p.turbidity = turbidity;
      p.sun = false;
      const EnvironmentMap m = make_sky_map(p);
      const double want = testing::preetham_horizontal_lux(turbidity, elevation);
      const double got = luminance(irradiance_lux(reduce_to_grid(m), {0, 1, 0}));
      EXPECT_NEAR(got, want, 0.01 * want) << elevation << " deg, T " << turbidity;
      // A clear sky gives roughly 5-30 klx on the ground besides the sun (measured daylight).
      if (turbidity == 2.0 && elevation >= 45) {
        EXPECT_GT(want, 5000);
        EXPECT_LT(want, 30000);
      }
      // The ground is a Lambertian of albedo 0.2 under the sky alone (sun off).
      EXPECT_NEAR(luminance(m.texel(0, m.height - 1)), 0.2 * got / kPi, 0.01 * 0.2 * got / kPi);
    }
}

TEST(Sky, ParseAndValidate) {
  auto s = parse_sky("35,120,3");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->sun_elevation_deg, 35);
  EXPECT_EQ(s->sun_azimuth_deg, 120);
  EXPECT_EQ(s->turbidity, 3);
  s = parse_sky("60");
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->sun_azimuth_deg, 0);
  EXPECT_EQ(s->turbidity, SkyParams{}.turbidity);
  for (const char* bad : {"", "a", "10,", ",10", "10,20,3,4", "-5", "95", "10,20,1", "10,20,11", "nan", "10,inf"}) {
    auto r = parse_sky(bad);
    EXPECT_FALSE(r.ok()) << bad;
  }
  EnvironmentSpec e;
  EXPECT_FALSE(validate_environment_spec(e).ok());  // neither file nor sky
  e.sky = SkyParams{};
  e.file = "x.exr";
  EXPECT_FALSE(validate_environment_spec(e).ok());  // both
  e.file.clear();
  e.scale = std::nan("");
  auto r = validate_environment_spec(e);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "environment.scale");
}

// ---- Loading --------------------------------------------------------------------------------

TEST(EnvironmentLoad, ExrWhiteLuminanceAndChromaticitiesAreHonoured) {
  hdrd::testing::TempDir dir;
  Image img(64, 32);
  for (std::size_t i = 0; i < img.pixel_count(); ++i) {
    img.rgba[i * 4] = 0.5f, img.rgba[i * 4 + 1] = 0.25f, img.rgba[i * 4 + 2] = 0.125f, img.rgba[i * 4 + 3] = 1;
  }
  io::ExrWriteOptions o;
  o.half = false;
  o.white_luminance = 80;  // scRGB-style: value x 80 = cd/m2
  ASSERT_TRUE(io::write_exr(dir / "a.exr", img, o).ok());
  std::vector<std::string> warnings;
  auto m = load_environment_map(dir / "a.exr", warnings);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_NEAR(m->texel(3, 3).x, 40, 1e-3);
  EXPECT_NEAR(m->texel(3, 3).z, 10, 1e-3);
  EXPECT_TRUE(warnings.empty());
  // Rec.2020 primaries: converted to the renderer's Rec.709 (BT.2087's inverse).
  o.chromaticities = color::kRec2020;
  o.white_luminance.reset();
  ASSERT_TRUE(io::write_exr(dir / "b.exr", img, o).ok());
  warnings.clear();
  m = load_environment_map(dir / "b.exr", warnings);
  ASSERT_TRUE(m.ok());
  const color::Vec3 want = color::inverse(color::kBt2087Rec709ToRec2020) * color::Vec3{0.5, 0.25, 0.125};
  EXPECT_NEAR(m->texel(0, 0).x, std::max(0.0, want.x), 2e-3);
  EXPECT_NEAR(m->texel(0, 0).y, std::max(0.0, want.y), 2e-3);
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("whiteLuminance"), std::string::npos);
}

TEST(EnvironmentLoad, BadFilesAreClearErrors) {
  hdrd::testing::TempDir dir;
  std::vector<std::string> w;
  auto r = load_environment_map(dir / "missing.exr", w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "environment.file");
  write_bytes(dir / "x.png", bytes_of("\x89PNG\r\n\x1a\nabcdefgh"));
  r = load_environment_map(dir / "x.png", w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "environment.format");
  write_bytes(dir / "square.hdr", radiance_file("", "-Y 4 +X 4", std::vector<std::uint8_t>(64, 128)));
  r = load_environment_map(dir / "square.hdr", w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "environment.layout");
  EXPECT_NE(r.error().message.find("twice as wide"), std::string::npos);
  // Issue 28.11: a 4x2 map is 2:1; what it lacks is rows, and the message says so.
  write_bytes(dir / "small.hdr", radiance_file("", "-Y 2 +X 4", std::vector<std::uint8_t>(32, 128)));
  r = load_environment_map(dir / "small.hdr", w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "environment.layout");
  EXPECT_EQ(r.error().message.find("twice as wide"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("at least 4 rows"), std::string::npos) << r.error().message;
  write_bytes(dir / "cut.hdr", radiance_file("", "-Y 4 +X 8", std::vector<std::uint8_t>(40, 128)));
  r = load_environment_map(dir / "cut.hdr", w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "hdr.truncated");
}

TEST(EnvironmentLoad, NonFiniteAndNegativeSamplesBecomeZeroWithAWarning) {
  hdrd::testing::TempDir dir;
  Image img(16, 8);
  for (std::size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = 1.0f;
  img.rgba[0] = std::nanf("");
  img.rgba[5] = INFINITY;
  img.rgba[10] = -2.0f;
  io::ExrWriteOptions o;
  o.half = false;
  ASSERT_TRUE(io::write_exr(dir / "bad.exr", img, o).ok());
  std::vector<std::string> w;
  auto m = load_environment_map(dir / "bad.exr", w);
  ASSERT_TRUE(m.ok()) << m.error().message;
  for (float v : m->rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0);
  EXPECT_EQ(m->rgb[0], 0.0f);
  EXPECT_EQ(m->rgb[4], 0.0f);  // pixel 1, green
  std::string all;
  for (const auto& s : w) all += s + "\n";
  EXPECT_NE(all.find("2 pixels with NaN or infinite"), std::string::npos) << all;
  EXPECT_NE(all.find("1 pixels with negative"), std::string::npos) << all;
}

}  // namespace
}  // namespace hdrd::shading

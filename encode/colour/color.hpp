// Colour spaces as data: primaries and white points, RGB<->XYZ matrices derived
// from chromaticities (SMPTE RP 177), Bradford adaptation, luminance, ICtCp (BT.2100).
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <span>
#include <string_view>

namespace hdrd::color {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3 operator+(Vec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(Vec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  friend constexpr bool operator==(Vec3, Vec3) = default;
};

// Row-major 3x3: m[r][c]. out = M * in.
struct Mat3 {
  std::array<std::array<double, 3>, 3> m{};
  static constexpr Mat3 identity() { return {{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}}; }
  constexpr Vec3 operator*(Vec3 v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  constexpr Mat3 operator*(const Mat3& o) const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        r.m[i][j] = m[i][0] * o.m[0][j] + m[i][1] * o.m[1][j] + m[i][2] * o.m[2][j];
    return r;
  }
};

Mat3 inverse(const Mat3& a);

struct Chromaticity {
  double x = 0, y = 0;
  friend constexpr bool operator==(Chromaticity, Chromaticity) = default;
};

// An RGB colour space's primaries and white point (CIE 1931 xy).
struct Primaries {
  Chromaticity red, green, blue, white;
  friend constexpr bool operator==(const Primaries&, const Primaries&) = default;
};

inline constexpr Chromaticity kD65{0.3127, 0.3290};
inline constexpr Chromaticity kDciWhite{0.314, 0.351};
inline constexpr Chromaticity kAcesWhite{0.32168, 0.33767};
inline constexpr Chromaticity kIlluminantE{1.0 / 3.0, 1.0 / 3.0};

inline constexpr Primaries kRec709{{0.640, 0.330}, {0.300, 0.600}, {0.150, 0.060}, kD65};
inline constexpr Primaries kRec2020{{0.708, 0.292}, {0.170, 0.797}, {0.131, 0.046}, kD65};
inline constexpr Primaries kDisplayP3{{0.680, 0.320}, {0.265, 0.690}, {0.150, 0.060}, kD65};
inline constexpr Primaries kDciP3{{0.680, 0.320}, {0.265, 0.690}, {0.150, 0.060}, kDciWhite};
inline constexpr Primaries kAcesAp0{{0.7347, 0.2653}, {0.0, 1.0}, {0.0001, -0.0770}, kAcesWhite};
inline constexpr Primaries kAcesAp1{{0.713, 0.293}, {0.165, 0.830}, {0.128, 0.044}, kAcesWhite};

// Named colour spaces. "xyz" is CIE XYZ itself (no primaries, never adapted).
enum class Space { rec709, rec2020, display_p3, dci_p3, aces_ap0, aces_ap1, xyz };

struct SpaceInfo {
  Space space;
  std::string_view name;         // canonical name: "rec709", "rec2020", ...
  std::string_view description;
  Primaries primaries;           // unused for xyz
};
std::span<const SpaceInfo> spaces();
std::optional<Space> find_space(std::string_view name);  // accepts aliases such as "srgb", "p3"
const SpaceInfo& info(Space s);

Vec3 xy_to_XYZ(Chromaticity c, double Y = 1.0);

// Normalised primary matrix (SMPTE RP 177-1993): RGB (white = 1,1,1) -> XYZ (white Y = 1).
Mat3 rgb_to_xyz(const Primaries& p);
Mat3 xyz_to_rgb(const Primaries& p);

// Bradford chromatic adaptation from one white to another (identity when equal).
Mat3 bradford(Chromaticity from_white, Chromaticity to_white);

// RGB in `from` to RGB in `to`; Bradford-adapts when the whites differ.
Mat3 rgb_to_rgb(const Primaries& from, const Primaries& to);
// Any named space to linear Rec.2020 D65 (the working space). XYZ is taken as
// D65-referred and never adapted (REFERENCE.md §1.1).
Mat3 to_working(Space s);
Mat3 from_working(Space s);

// Luminance Y of linear RGB in the given primaries (the matrix's middle row).
Vec3 luminance_weights(const Primaries& p);
inline constexpr Vec3 kRec709Luma{0.2126, 0.7152, 0.0722};
inline constexpr Vec3 kRec2020Luma{0.2627, 0.6780, 0.0593};
inline constexpr double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// ICtCp (BT.2100, PQ variant). Input: linear Rec.2020 in absolute cd/m2.
Vec3 rec2020_nits_to_ictcp(Vec3 rgb_nits);
Vec3 ictcp_to_rec2020_nits(Vec3 ictcp);

// Published BT.2087 Rec.709 -> Rec.2020 matrix (4 decimals), for tests and docs only;
// the code derives its own.
inline constexpr Mat3 kBt2087Rec709ToRec2020{{{{0.6274, 0.3293, 0.0433},
                                              {0.0691, 0.9195, 0.0114},
                                              {0.0164, 0.0880, 0.8956}}}};

}  // namespace hdrd::color

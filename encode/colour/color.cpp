#include "encode/colour/color.hpp"

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <string>

#include "encode/colour/transfer.hpp"

namespace hdrd::color {

Mat3 inverse(const Mat3& a) {
  const auto& m = a.m;
  const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
  const double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
  const double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  const double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
  if (std::abs(det) < 1e-300) throw std::domain_error("singular colour matrix");
  const double s = 1.0 / det;
  Mat3 r;
  r.m[0] = {c00 * s, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * s, (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * s};
  r.m[1] = {c01 * s, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * s, (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * s};
  r.m[2] = {c02 * s, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * s, (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * s};
  return r;
}

Vec3 xy_to_XYZ(Chromaticity c, double Y) {
  return {c.x * Y / c.y, Y, (1.0 - c.x - c.y) * Y / c.y};
}

Mat3 rgb_to_xyz(const Primaries& p) {
  const Vec3 r = xy_to_XYZ(p.red), g = xy_to_XYZ(p.green), b = xy_to_XYZ(p.blue);
  Mat3 prim{{{{r.x, g.x, b.x}, {r.y, g.y, b.y}, {r.z, g.z, b.z}}}};
  const Vec3 s = inverse(prim) * xy_to_XYZ(p.white);  // scale so RGB white -> XYZ white
  for (int i = 0; i < 3; ++i) {
    prim.m[i][0] *= s.x;
    prim.m[i][1] *= s.y;
    prim.m[i][2] *= s.z;
  }
  return prim;
}

Mat3 xyz_to_rgb(const Primaries& p) { return inverse(rgb_to_xyz(p)); }

Mat3 bradford(Chromaticity from_white, Chromaticity to_white) {
  if (from_white == to_white) return Mat3::identity();
  static constexpr Mat3 kBradford{{{{0.8951, 0.2664, -0.1614},
                                    {-0.7502, 1.7135, 0.0367},
                                    {0.0389, -0.0685, 1.0296}}}};
  const Vec3 src = kBradford * xy_to_XYZ(from_white);
  const Vec3 dst = kBradford * xy_to_XYZ(to_white);
  Mat3 scale{{{{dst.x / src.x, 0, 0}, {0, dst.y / src.y, 0}, {0, 0, dst.z / src.z}}}};
  return inverse(kBradford) * scale * kBradford;
}

Mat3 rgb_to_rgb(const Primaries& from, const Primaries& to) {
  return xyz_to_rgb(to) * bradford(from.white, to.white) * rgb_to_xyz(from);
}

namespace {
constexpr SpaceInfo kSpaces[] = {
    {Space::rec709, "rec709", "ITU-R BT.709 / sRGB primaries, D65", kRec709},
    {Space::rec2020, "rec2020", "ITU-R BT.2020 primaries, D65 (the working space)", kRec2020},
    {Space::display_p3, "display-p3", "P3 primaries, D65 (Display P3, P3-D65)", kDisplayP3},
    {Space::dci_p3, "dci-p3", "P3 primaries, DCI white (0.314, 0.351)", kDciP3},
    {Space::aces_ap0, "aces-ap0", "ACES 2065-1 AP0 primaries, ACES white", kAcesAp0},
    {Space::aces_ap1, "aces-ap1", "ACEScg AP1 primaries, ACES white", kAcesAp1},
    {Space::xyz, "xyz", "CIE 1931 XYZ, taken as D65-referred (never adapted)", kRec709},
};

struct Alias {
  std::string_view alias;
  Space space;
};
constexpr Alias kAliases[] = {
    {"srgb", Space::rec709},      {"bt709", Space::rec709},      {"709", Space::rec709},
    {"bt2020", Space::rec2020},   {"2020", Space::rec2020},      {"p3", Space::display_p3},
    {"p3-d65", Space::display_p3}, {"displayp3", Space::display_p3}, {"p3-dci", Space::dci_p3},
    {"ap0", Space::aces_ap0},     {"aces", Space::aces_ap0},     {"aces2065-1", Space::aces_ap0},
    {"ap1", Space::aces_ap1},     {"acescg", Space::aces_ap1},   {"ciexyz", Space::xyz},
};
}  // namespace

std::span<const SpaceInfo> spaces() { return kSpaces; }

std::optional<Space> find_space(std::string_view name) {
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const auto& s : kSpaces)
    if (s.name == lower) return s.space;
  for (const auto& a : kAliases)
    if (a.alias == lower) return a.space;
  return std::nullopt;
}

const SpaceInfo& info(Space s) {
  for (const auto& i : kSpaces)
    if (i.space == s) return i;
  throw std::logic_error("unknown colour space");
}

Mat3 to_working(Space s) {
  if (s == Space::xyz) return xyz_to_rgb(kRec2020);
  return rgb_to_rgb(info(s).primaries, kRec2020);
}

Mat3 from_working(Space s) { return inverse(to_working(s)); }

Vec3 luminance_weights(const Primaries& p) {
  const Mat3 m = rgb_to_xyz(p);
  return {m.m[1][0], m.m[1][1], m.m[1][2]};
}

// BT.2100 ICtCp, PQ variant: LMS from Rec.2020, PQ per channel, then the ICtCp matrix.
namespace {
constexpr Mat3 kRec2020ToLms{{{{1688 / 4096.0, 2146 / 4096.0, 262 / 4096.0},
                               {683 / 4096.0, 2951 / 4096.0, 462 / 4096.0},
                               {99 / 4096.0, 309 / 4096.0, 3688 / 4096.0}}}};
constexpr Mat3 kLmsPqToIctcp{{{{2048 / 4096.0, 2048 / 4096.0, 0},
                               {6610 / 4096.0, -13613 / 4096.0, 7003 / 4096.0},
                               {17933 / 4096.0, -17390 / 4096.0, -543 / 4096.0}}}};
}  // namespace

Vec3 rec2020_nits_to_ictcp(Vec3 rgb) {
  const Vec3 lms = kRec2020ToLms * rgb;
  const Vec3 lms_pq{transfer::pq_inverse_eotf(lms.x), transfer::pq_inverse_eotf(lms.y),
                    transfer::pq_inverse_eotf(lms.z)};
  return kLmsPqToIctcp * lms_pq;
}

Vec3 ictcp_to_rec2020_nits(Vec3 ictcp) {
  static const Mat3 kIctcpToLmsPq = inverse(kLmsPqToIctcp);
  static const Mat3 kLmsToRec2020 = inverse(kRec2020ToLms);
  const Vec3 lms_pq = kIctcpToLmsPq * ictcp;
  const Vec3 lms{transfer::pq_eotf(lms_pq.x), transfer::pq_eotf(lms_pq.y), transfer::pq_eotf(lms_pq.z)};
  return kLmsToRec2020 * lms;
}

}  // namespace hdrd::color

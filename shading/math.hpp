// Small linear-algebra kit for scene set-up (double precision on the CPU; the GPU
// receives float copies). Column vectors, column-major 4x4 matrices as GLSL expects.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace hdrd::shading {

inline constexpr double kPi = 3.14159265358979323846;

struct Vec3 {
  double x = 0, y = 0, z = 0;
  constexpr Vec3 operator+(Vec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(Vec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3 operator*(Vec3 o) const { return {x * o.x, y * o.y, z * o.z}; }  // per channel
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  friend constexpr bool operator==(Vec3, Vec3) = default;
};

inline constexpr double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline constexpr Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Vec3 v) { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(Vec3 v) {
  const double l = length(v);
  return l > 0 ? v / l : Vec3{0, 0, 0};
}
inline bool is_finite(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
inline Vec3 vmin(Vec3 a, Vec3 b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3 vmax(Vec3 a, Vec3 b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
// Rec.709 luminance weights (the renderer's colours are linear Rec.709).
inline constexpr double luminance(Vec3 rgb) { return 0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z; }

// Column-major 4x4: m[col * 4 + row], the layout glUniformMatrix4fv and std140 take.
struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  constexpr double& at(int row, int col) { return m[col * 4 + row]; }
  constexpr double at(int row, int col) const { return m[col * 4 + row]; }
  static constexpr Mat4 identity() { return {}; }
  constexpr Mat4 operator*(const Mat4& o) const {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += at(i, k) * o.at(k, j);
        r.at(i, j) = s;
      }
    return r;
  }
  constexpr Vec3 transform_point(Vec3 p) const {
    const double w = at(3, 0) * p.x + at(3, 1) * p.y + at(3, 2) * p.z + at(3, 3);
    const Vec3 r{at(0, 0) * p.x + at(0, 1) * p.y + at(0, 2) * p.z + at(0, 3),
                 at(1, 0) * p.x + at(1, 1) * p.y + at(1, 2) * p.z + at(1, 3),
                 at(2, 0) * p.x + at(2, 1) * p.y + at(2, 2) * p.z + at(2, 3)};
    return w != 0 && w != 1 ? r / w : r;
  }
  constexpr Vec3 transform_dir(Vec3 d) const {
    return {at(0, 0) * d.x + at(0, 1) * d.y + at(0, 2) * d.z,
            at(1, 0) * d.x + at(1, 1) * d.y + at(1, 2) * d.z,
            at(2, 0) * d.x + at(2, 1) * d.y + at(2, 2) * d.z};
  }
};

Mat4 translate(Vec3 t);
Mat4 scale(Vec3 s);
Mat4 rotate_xyz_deg(Vec3 euler_deg);  // R = Rz * Ry * Rx (X applied first)
Mat4 from_quaternion(double x, double y, double z, double w);
Mat4 look_at(Vec3 eye, Vec3 target, Vec3 up);                                  // world -> view
Mat4 perspective(double yfov_rad, double aspect, double znear, double zfar);   // GL clip, z in [-1, 1]
Mat4 orthographic(double l, double r, double b, double t, double n, double f);
Mat4 inverse(const Mat4& a);  // general inverse; identity-scaled garbage if singular (check det first)
double determinant(const Mat4& a);
Mat4 transpose(const Mat4& a);
// Inverse-transpose of the upper 3x3 (for normals), in a Mat4.
Mat4 normal_matrix(const Mat4& model);
bool is_finite(const Mat4& a);

}  // namespace hdrd::shading

#include "shading/math.hpp"

namespace hdrd::shading {

Mat4 translate(Vec3 t) {
  Mat4 r;
  r.at(0, 3) = t.x;
  r.at(1, 3) = t.y;
  r.at(2, 3) = t.z;
  return r;
}

Mat4 scale(Vec3 s) {
  Mat4 r;
  r.at(0, 0) = s.x;
  r.at(1, 1) = s.y;
  r.at(2, 2) = s.z;
  return r;
}

Mat4 rotate_xyz_deg(Vec3 e) {
  const double k = kPi / 180.0;
  const double cx = std::cos(e.x * k), sx = std::sin(e.x * k);
  const double cy = std::cos(e.y * k), sy = std::sin(e.y * k);
  const double cz = std::cos(e.z * k), sz = std::sin(e.z * k);
  Mat4 rx, ry, rz;
  rx.at(1, 1) = cx; rx.at(1, 2) = -sx; rx.at(2, 1) = sx; rx.at(2, 2) = cx;
  ry.at(0, 0) = cy; ry.at(0, 2) = sy; ry.at(2, 0) = -sy; ry.at(2, 2) = cy;
  rz.at(0, 0) = cz; rz.at(0, 1) = -sz; rz.at(1, 0) = sz; rz.at(1, 1) = cz;
  return rz * ry * rx;
}

Mat4 from_quaternion(double x, double y, double z, double w) {
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  if (n > 0) { x /= n; y /= n; z /= n; w /= n; }
  Mat4 r;
  r.at(0, 0) = 1 - 2 * (y * y + z * z); r.at(0, 1) = 2 * (x * y - z * w); r.at(0, 2) = 2 * (x * z + y * w);
  r.at(1, 0) = 2 * (x * y + z * w); r.at(1, 1) = 1 - 2 * (x * x + z * z); r.at(1, 2) = 2 * (y * z - x * w);
  r.at(2, 0) = 2 * (x * z - y * w); r.at(2, 1) = 2 * (y * z + x * w); r.at(2, 2) = 1 - 2 * (x * x + y * y);
  return r;
}

Mat4 look_at(Vec3 eye, Vec3 target, Vec3 up) {
  const Vec3 f = normalize(target - eye);
  Vec3 s = normalize(cross(f, up));
  if (length(s) == 0) s = normalize(cross(f, std::abs(f.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}));
  const Vec3 u = cross(s, f);
  Mat4 r;
  r.at(0, 0) = s.x; r.at(0, 1) = s.y; r.at(0, 2) = s.z; r.at(0, 3) = -dot(s, eye);
  r.at(1, 0) = u.x; r.at(1, 1) = u.y; r.at(1, 2) = u.z; r.at(1, 3) = -dot(u, eye);
  r.at(2, 0) = -f.x; r.at(2, 1) = -f.y; r.at(2, 2) = -f.z; r.at(2, 3) = dot(f, eye);
  return r;
}

Mat4 perspective(double yfov_rad, double aspect, double znear, double zfar) {
  const double t = 1.0 / std::tan(yfov_rad / 2);
  Mat4 r;
  r.m.fill(0);
  r.at(0, 0) = t / aspect;
  r.at(1, 1) = t;
  r.at(2, 2) = (zfar + znear) / (znear - zfar);
  r.at(2, 3) = 2 * zfar * znear / (znear - zfar);
  r.at(3, 2) = -1;
  return r;
}

Mat4 orthographic(double l, double r, double b, double t, double n, double f) {
  Mat4 o;
  o.at(0, 0) = 2 / (r - l);
  o.at(1, 1) = 2 / (t - b);
  o.at(2, 2) = -2 / (f - n);
  o.at(0, 3) = -(r + l) / (r - l);
  o.at(1, 3) = -(t + b) / (t - b);
  o.at(2, 3) = -(f + n) / (f - n);
  return o;
}

Mat4 transpose(const Mat4& a) {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.at(i, j) = a.at(j, i);
  return r;
}

namespace {
// Cofactor expansion (the classic MESA gluInvertMatrix layout), on column-major m[].
std::array<double, 16> adjugate(const std::array<double, 16>& m) {
  std::array<double, 16> inv{};
  inv[0] = m[5] * m[10] * m[15] - m[5] * m[11] * m[14] - m[9] * m[6] * m[15] + m[9] * m[7] * m[14] + m[13] * m[6] * m[11] - m[13] * m[7] * m[10];
  inv[4] = -m[4] * m[10] * m[15] + m[4] * m[11] * m[14] + m[8] * m[6] * m[15] - m[8] * m[7] * m[14] - m[12] * m[6] * m[11] + m[12] * m[7] * m[10];
  inv[8] = m[4] * m[9] * m[15] - m[4] * m[11] * m[13] - m[8] * m[5] * m[15] + m[8] * m[7] * m[13] + m[12] * m[5] * m[11] - m[12] * m[7] * m[9];
  inv[12] = -m[4] * m[9] * m[14] + m[4] * m[10] * m[13] + m[8] * m[5] * m[14] - m[8] * m[6] * m[13] - m[12] * m[5] * m[10] + m[12] * m[6] * m[9];
  inv[1] = -m[1] * m[10] * m[15] + m[1] * m[11] * m[14] + m[9] * m[2] * m[15] - m[9] * m[3] * m[14] - m[13] * m[2] * m[11] + m[13] * m[3] * m[10];
  inv[5] = m[0] * m[10] * m[15] - m[0] * m[11] * m[14] - m[8] * m[2] * m[15] + m[8] * m[3] * m[14] + m[12] * m[2] * m[11] - m[12] * m[3] * m[10];
  inv[9] = -m[0] * m[9] * m[15] + m[0] * m[11] * m[13] + m[8] * m[1] * m[15] - m[8] * m[3] * m[13] - m[12] * m[1] * m[11] + m[12] * m[3] * m[9];
  inv[13] = m[0] * m[9] * m[14] - m[0] * m[10] * m[13] - m[8] * m[1] * m[14] + m[8] * m[2] * m[13] + m[12] * m[1] * m[10] - m[12] * m[2] * m[9];
  inv[2] = m[1] * m[6] * m[15] - m[1] * m[7] * m[14] - m[5] * m[2] * m[15] + m[5] * m[3] * m[14] + m[13] * m[2] * m[7] - m[13] * m[3] * m[6];
  inv[6] = -m[0] * m[6] * m[15] + m[0] * m[7] * m[14] + m[4] * m[2] * m[15] - m[4] * m[3] * m[14] - m[12] * m[2] * m[7] + m[12] * m[3] * m[6];
  inv[10] = m[0] * m[5] * m[15] - m[0] * m[7] * m[13] - m[4] * m[1] * m[15] + m[4] * m[3] * m[13] + m[12] * m[1] * m[7] - m[12] * m[3] * m[5];
  inv[14] = -m[0] * m[5] * m[14] + m[0] * m[6] * m[13] + m[4] * m[1] * m[14] - m[4] * m[2] * m[13] - m[12] * m[1] * m[6] + m[12] * m[2] * m[5];
  inv[3] = -m[1] * m[6] * m[11] + m[1] * m[7] * m[10] + m[5] * m[2] * m[11] - m[5] * m[3] * m[10] - m[9] * m[2] * m[7] + m[9] * m[3] * m[6];
  inv[7] = m[0] * m[6] * m[11] - m[0] * m[7] * m[10] - m[4] * m[2] * m[11] + m[4] * m[3] * m[10] + m[8] * m[2] * m[7] - m[8] * m[3] * m[6];
  inv[11] = -m[0] * m[5] * m[11] + m[0] * m[7] * m[9] + m[4] * m[1] * m[11] - m[4] * m[3] * m[9] - m[8] * m[1] * m[7] + m[8] * m[3] * m[5];
  inv[15] = m[0] * m[5] * m[10] - m[0] * m[6] * m[9] - m[4] * m[1] * m[10] + m[4] * m[2] * m[9] + m[8] * m[1] * m[6] - m[8] * m[2] * m[5];
  return inv;
}
}  // namespace

double determinant(const Mat4& a) {
  const auto inv = adjugate(a.m);
  return a.m[0] * inv[0] + a.m[1] * inv[4] + a.m[2] * inv[8] + a.m[3] * inv[12];
}

Mat4 inverse(const Mat4& a) {
  const auto inv = adjugate(a.m);
  const double det = a.m[0] * inv[0] + a.m[1] * inv[4] + a.m[2] * inv[8] + a.m[3] * inv[12];
  Mat4 r;
  if (det == 0 || !std::isfinite(det)) return r;
  for (int i = 0; i < 16; ++i) r.m[i] = inv[i] / det;
  return r;
}

Mat4 normal_matrix(const Mat4& model) {
  Mat4 upper = model;
  for (int i = 0; i < 3; ++i) {
    upper.at(i, 3) = 0;
    upper.at(3, i) = 0;
  }
  upper.at(3, 3) = 1;
  return transpose(inverse(upper));
}

bool is_finite(const Mat4& a) {
  for (double v : a.m)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace hdrd::shading

#include "shading/shadows.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace hdrd::shading {
namespace {

struct Box {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  void add(Vec3 p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
};

std::array<Vec3, 8> corners(const Bounds& b) {
  std::array<Vec3, 8> c;
  for (int i = 0; i < 8; ++i)
    c[static_cast<std::size_t>(i)] = {i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y, i & 4 ? b.max.z : b.min.z};
  return c;
}

std::array<Vec3, 8> frustum_corners(const Camera& cam, double aspect, double znear, double zfar) {
  const Vec3 f = normalize(cam.target - cam.position);
  Vec3 r = normalize(cross(f, cam.up));
  if (length(r) < 0.5) r = normalize(cross(f, std::abs(f.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}));
  const Vec3 u = cross(r, f);
  std::array<Vec3, 8> c;
  const double t = std::tan(cam.yfov_rad / 2);
  for (int i = 0; i < 8; ++i) {
    const double d = i & 4 ? zfar : znear, hh = d * t, hw = hh * aspect;
    c[static_cast<std::size_t>(i)] = cam.position + f * d + r * (i & 1 ? hw : -hw) + u * (i & 2 ? hh : -hh);
  }
  return c;
}

// The twelve edges of a box-like solid whose corner i has bits (x, y, z).
constexpr int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

struct Plane {
  Vec3 n;
  double d;  // inside: dot(n, p) + d >= 0
};

// The frustum's six planes, normals inward (corner bits: x right, y up, z far).
std::array<Plane, 6> frustum_planes(const std::array<Vec3, 8>& c) {
  const auto plane = [&](int a, int b, int d, int inside) {
    Vec3 n = normalize(cross(c[b] - c[a], c[d] - c[a]));
    if (dot(n, c[inside] - c[a]) < 0) n = -n;
    return Plane{n, -dot(n, c[a])};
  };
  return {plane(0, 2, 4, 1), plane(1, 3, 5, 0), plane(0, 1, 4, 2), plane(2, 3, 6, 0), plane(0, 1, 2, 4), plane(4, 5, 6, 0)};
}

// Clips the segment a-b to the planes; false when nothing is left.
bool clip_to_planes(Vec3& a, Vec3& b, const std::array<Plane, 6>& planes) {
  double t0 = 0, t1 = 1;
  for (const Plane& p : planes) {
    const double da = dot(p.n, a) + p.d, db = dot(p.n, b) + p.d;
    if (da < 0 && db < 0) return false;
    if (da < 0) t0 = std::max(t0, da / (da - db));
    if (db < 0) t1 = std::min(t1, da / (da - db));
  }
  if (t0 > t1) return false;
  const Vec3 d = b - a;
  b = a + d * t1;
  a = a + d * t0;
  return true;
}

std::array<Plane, 6> box_planes(const Bounds& b) {
  return {Plane{{1, 0, 0}, -b.min.x}, Plane{{-1, 0, 0}, b.max.x}, Plane{{0, 1, 0}, -b.min.y},
          Plane{{0, -1, 0}, b.max.y}, Plane{{0, 0, 1}, -b.min.z}, Plane{{0, 0, -1}, b.max.z}};
}

// Points whose bounding box holds the intersection of the view frustum and the scene's
// box: the vertices of that convex solid lie on the edges of one, clipped by the other.
std::vector<Vec3> visible_region(const std::array<Vec3, 8>& frustum, const Bounds& scene) {
  Bounds padded = scene;  // a flat floor has a box of zero height
  const Vec3 pad = Vec3{1, 1, 1} * (1e-4 * std::max(scene.radius(), 1e-3));
  padded.min = scene.min - pad;
  padded.max = scene.max + pad;
  const auto box = corners(padded);
  const auto fp = frustum_planes(frustum), bp = box_planes(padded);
  std::vector<Vec3> out;
  for (const auto& e : kEdges) {
    Vec3 a = frustum[static_cast<std::size_t>(e[0])], b = frustum[static_cast<std::size_t>(e[1])];
    if (clip_to_planes(a, b, bp)) out.insert(out.end(), {a, b});
    a = box[static_cast<std::size_t>(e[0])], b = box[static_cast<std::size_t>(e[1])];
    if (clip_to_planes(a, b, fp)) out.insert(out.end(), {a, b});
  }
  return out;
}

}  // namespace

ShadowFit fit_shadow(const Light& light, const Bounds& scene, const Camera& camera, double aspect, double znear,
                     double zfar, int size) {
  const Vec3 dir = normalize(light.direction);
  const Vec3 up = std::abs(dir.y) > 0.99 ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
  const Vec3 c = scene.center();
  const double radius = std::max(scene.radius(), 1e-3);
  const Mat4 view = look_at(c - dir * (2 * radius), c, up);
  Box s, f;
  for (const Vec3& p : corners(scene)) s.add(view.transform_point(p));
  for (const Vec3& p : visible_region(frustum_corners(camera, aspect, znear, zfar), scene)) f.add(view.transform_point(p));
  double x0 = f.lo.x, x1 = f.hi.x, y0 = f.lo.y, y1 = f.hi.y;
  if (!(x1 > x0 && y1 > y0)) {  // the camera sees none of the scene: cover all of it
    x0 = s.lo.x, x1 = s.hi.x, y0 = s.lo.y, y1 = s.hi.y;
  }
  // A square, one texel of margin, snapped to the texel grid.
  const double extent = std::max({x1 - x0, y1 - y0, 1e-3}) * double(size) / (size - 2);
  const double texel = extent / size;
  const double cx = std::floor((x0 + x1) / 2 / texel) * texel, cy = std::floor((y0 + y1) / 2 / texel) * texel;
  const double margin = 0.01 * radius + texel;
  const double znear_l = std::max(1e-4, -s.hi.z - margin), zfar_l = -s.lo.z + margin;
  ShadowFit fit;
  fit.light_clip = orthographic(cx - extent / 2, cx + extent / 2, cy - extent / 2, cy + extent / 2, znear_l, zfar_l) * view;
  fit.texel_m = texel;
  return fit;
}

}  // namespace hdrd::shading

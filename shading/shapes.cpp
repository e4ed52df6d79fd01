#include "shading/shapes.hpp"

#include <algorithm>

namespace hdrd::shading {
namespace {

std::array<float, 3> f3(Vec3 v) { return {float(v.x), float(v.y), float(v.z)}; }
Vec3 v3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

void push_quad(Mesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
}

// A tangent perpendicular to n, for vertices without a usable uv gradient.
Vec3 any_perpendicular(Vec3 n) {
  const Vec3 axis = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return normalize(cross(axis, n));
}

}  // namespace

Mesh make_sphere(double radius_m, int segments, int rings) {
  segments = std::clamp(segments, 3, kMaxSphereSegments);
  rings = std::clamp(rings, 2, kMaxSphereSegments);
  Mesh m;
  m.name = "sphere";
  for (int r = 0; r <= rings; ++r) {
    const double theta = kPi * r / rings;  // from +y
    for (int s = 0; s <= segments; ++s) {
      const double phi = 2 * kPi * s / segments;
      const Vec3 n{std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
      Vertex v;
      v.position = f3(n * radius_m);
      v.normal = f3(n);
      const Vec3 t = normalize(Vec3{-std::sin(phi), 0, -std::cos(phi)});  // d(position)/d(phi)
      v.tangent = {float(t.x), float(t.y), float(t.z), 1.0f};
      v.uv = {float(s) / segments, float(r) / rings};
      m.vertices.push_back(v);
    }
  }
  const auto row = static_cast<std::uint32_t>(segments + 1);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const std::uint32_t a = r * row + s, b = a + row;
      if (r != 0) m.indices.insert(m.indices.end(), {a, b, a + 1});
      if (r != rings - 1) m.indices.insert(m.indices.end(), {a + 1, b, b + 1});
    }
  return m;
}

Mesh make_plane(double size_x_m, double size_z_m) {
  Mesh m;
  m.name = "plane";
  const double hx = size_x_m / 2, hz = size_z_m / 2;
  const Vec3 corners[4] = {{-hx, 0, hz}, {hx, 0, hz}, {hx, 0, -hz}, {-hx, 0, -hz}};
  const float uvs[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  for (int i = 0; i < 4; ++i) {
    Vertex v;
    v.position = f3(corners[i]);
    v.normal = {0, 1, 0};
    v.tangent = {1, 0, 0, 1};
    v.uv = {uvs[i][0], uvs[i][1]};
    m.vertices.push_back(v);
  }
  push_quad(m, 0, 1, 2, 3);
  return m;
}

Mesh make_box(Vec3 size_m) {
  Mesh m;
  m.name = "box";
  const Vec3 h = size_m * 0.5;
  // Each face: normal, and two in-plane axes u, v with u x v = normal.
  const Vec3 faces[6][3] = {{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}, {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
                            {{0, 1, 0}, {1, 0, 0}, {0, 0, -1}}, {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
                            {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},  {{0, 0, -1}, {-1, 0, 0}, {0, 1, 0}}};
  for (const auto& f : faces) {
    const Vec3 n = f[0], u = f[1], v = f[2];
    const auto base = static_cast<std::uint32_t>(m.vertices.size());
    const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int i = 0; i < 4; ++i) {
      const Vec3 p = n * h + (u * h) * su[i] + (v * h) * sv[i];  // axis * h picks that half extent
      Vertex vert;
      vert.position = f3(p);
      vert.normal = f3(n);
      vert.tangent = {float(u.x), float(u.y), float(u.z), 1.0f};
      vert.uv = {float((su[i] + 1) / 2), float((1 - sv[i]) / 2)};
      m.vertices.push_back(vert);
    }
    push_quad(m, base, base + 1, base + 2, base + 3);
  }
  return m;
}

void compute_normals(Mesh& m) {
  std::vector<Vec3> acc(m.vertices.size(), Vec3{0, 0, 0});
  for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3) {
    const auto a = m.indices[i], b = m.indices[i + 1], c = m.indices[i + 2];
    const Vec3 pa = v3(m.vertices[a].position), pb = v3(m.vertices[b].position), pc = v3(m.vertices[c].position);
    const Vec3 n = cross(pb - pa, pc - pa);  // length = 2 * area: area weighting
    acc[a] = acc[a] + n;
    acc[b] = acc[b] + n;
    acc[c] = acc[c] + n;
  }
  for (std::size_t i = 0; i < acc.size(); ++i) {
    const Vec3 n = length(acc[i]) > 0 ? normalize(acc[i]) : Vec3{0, 0, 1};
    m.vertices[i].normal = f3(n);
  }
}

void compute_tangents(Mesh& m) {
  std::vector<Vec3> tan(m.vertices.size(), Vec3{0, 0, 0}), bit(m.vertices.size(), Vec3{0, 0, 0});
  for (std::size_t i = 0; i + 2 < m.indices.size(); i += 3) {
    const std::uint32_t idx[3] = {m.indices[i], m.indices[i + 1], m.indices[i + 2]};
    const Vertex &a = m.vertices[idx[0]], &b = m.vertices[idx[1]], &c = m.vertices[idx[2]];
    const Vec3 e1 = v3(b.position) - v3(a.position), e2 = v3(c.position) - v3(a.position);
    const double du1 = b.uv[0] - a.uv[0], dv1 = b.uv[1] - a.uv[1];
    const double du2 = c.uv[0] - a.uv[0], dv2 = c.uv[1] - a.uv[1];
    const double det = du1 * dv2 - du2 * dv1;
    if (std::abs(det) < 1e-20) continue;
    const Vec3 t = (e1 * dv2 - e2 * dv1) / det, bt = (e2 * du1 - e1 * du2) / det;
    for (auto k : idx) {
      tan[k] = tan[k] + t;
      bit[k] = bit[k] + bt;
    }
  }
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3 n = v3(m.vertices[i].normal);
    Vec3 t = tan[i] - n * dot(n, tan[i]);  // Gram-Schmidt
    t = length(t) > 1e-12 ? normalize(t) : any_perpendicular(n);
    // glTF: bitangent = cross(n, t) * w points to the image's top, i.e. along -dP/dv
    // (uv origin at the top left); w = -1 only for mirrored uv layouts.
    const double w = dot(cross(n, t), bit[i]) > 0 ? -1.0 : 1.0;
    m.vertices[i].tangent = {float(t.x), float(t.y), float(t.z), float(w)};
  }
}

}  // namespace hdrd::shading

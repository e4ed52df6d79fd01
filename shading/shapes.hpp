// Procedural meshes for built-in and JSON scenes, and the vertex attributes glTF files
// may leave out (normals, tangents).
#pragma once

#include "shading/scene.hpp"

namespace hdrd::shading {

inline constexpr int kMaxSphereSegments = 512;

// UV sphere centred at the origin; u runs with longitude, v from north to south pole.
Mesh make_sphere(double radius_m, int segments = 48, int rings = 24);
// Square in the xz plane facing +y, size_x by size_z, uv [0,1]^2.
Mesh make_plane(double size_x_m, double size_z_m);
// Axis-aligned box centred at the origin with per-face normals.
Mesh make_box(Vec3 size_m);

// Smooth normals from the triangles (area-weighted).
void compute_normals(Mesh& m);
// Per-vertex tangents from uv derivatives (Lengyel's method, MikkTSpace-like
// orthogonalisation and handedness). Vertices without a uv gradient get any tangent
// perpendicular to the normal.
void compute_tangents(Mesh& m);

}  // namespace hdrd::shading

// The sun's shadow map: an orthographic depth map along the brightest shadow-casting
// directional light, fitted to what the camera sees.
//
// Fit: the part of the scene's bounding box inside the view frustum (near to far plane),
// boxed in light space; the map covers that box in x and y (a square whose centre snaps
// to the texel grid) and the scene's whole depth range along the light (casters outside
// the view still shadow what it sees).
//
// Bias rules (docs/rendering.md, "Shadows"): (1) the depth pass draws with a slope-scaled
// polygon offset (factor 2, units 4); (2) each receiver looks itself up from a point moved
// along its geometric normal by 1.5 texels x (0.5 + sin theta), theta the angle between
// normal and light, so the offset grows where acne would; (3) filtering is 3x3 PCF over
// the hardware's 2x2 comparison (a 4x4-texel footprint).
#pragma once

#include "shading/scene.hpp"

namespace hdrd::shading {

struct ShadowFit {
  Mat4 light_clip;     // world -> shadow-map clip space
  double texel_m = 0;  // world size of one shadow-map texel
};

ShadowFit fit_shadow(const Light& light, const Bounds& scene, const Camera& camera, double aspect, double znear,
                     double zfar, int size);

// The normal offset of rule (2) at normal incidence, in texels (times 0.5 + sin theta).
inline constexpr double kShadowNormalOffsetTexels = 1.5;

}  // namespace hdrd::shading

// GLSL sources of the renderer's programs. Each function returns a complete source for
// the context's flavour (GL 4.5 core or GLES 3.2); constants shared with C++ (block
// sizes, texture units, BRDF clamps) are printed from gpu_blocks.hpp / brdf.hpp.
#pragma once

#include <string>

#include "shading/gl_api.hpp"

namespace hdrd::shading::shaders {

std::string lit_vertex(const GlApi& gl);
std::string lit_fragment(const GlApi& gl);
std::string shadow_vertex(const GlApi& gl);
std::string shadow_fragment(const GlApi& gl);
std::string fullscreen_vertex(const GlApi& gl);
// MSAA resolve weighted by 1 / (1 + exposure * luma) (RTR4 §5.4.2, Karis 2014): bright
// samples no longer dominate an edge pixel, so edges survive tone mapping.
std::string resolve_fragment(const GlApi& gl);
// The environment behind the scene (equirectangular map + the sky's sun disc).
std::string background_vertex(const GlApi& gl);
std::string background_fragment(const GlApi& gl);
// Environment prefiltering (full-screen passes into cube-map faces): the equirectangular
// map resampled into a cube, and the GGX-prefiltered mip chain of that cube.
std::string equirect_to_cube_fragment(const GlApi& gl);
std::string prefilter_ggx_fragment(const GlApi& gl);
// Block means of the frame for a reduced readback (exposure metering), undoing pre-exposure.
std::string reduce_fragment(const GlApi& gl);

}  // namespace hdrd::shading::shaders

// parity_ibl_lookups.comp - lib/ibl.glsl's sampler lookups (ibl_specular_radiance, ibl_dfg,
// ibl_dominant_factor) on a list of inputs, for the parity check against learned.twins.ibl
// (learned/parity/checks/ibl.py).
#include "lib/ibl.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_pre;
uniform sampler2D u_lut;
uniform sampler2D u_dominant;
uniform float u_levels;
layout(std430, binding = 0) readonly buffer In { float inv[]; };   // [n][5] dir, r, NoV
layout(std430, binding = 1) writeonly buffer Out { float outv[]; }; // [n][6] rgb, dfg, t
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 d = vec3(inv[5u * i], inv[5u * i + 1u], inv[5u * i + 2u]);
    vec3 s = ibl_specular_radiance(u_pre, d, inv[5u * i + 3u], u_levels);
    vec2 g = ibl_dfg(u_lut, inv[5u * i + 4u], inv[5u * i + 3u]);
    float t = ibl_dominant_factor(u_dominant, inv[5u * i + 4u], inv[5u * i + 3u]);
    outv[6u * i] = s.x; outv[6u * i + 1u] = s.y; outv[6u * i + 2u] = s.z;
    outv[6u * i + 3u] = g.x; outv[6u * i + 4u] = g.y; outv[6u * i + 5u] = t;
}

// parity_ibl_lookups.comp - lib/ibl.glsl's sampler lookups (ibl_specular_radiance, ibl_dfg,
// ibl_dominant_factor, ibl_specular_radiance_sun with u_pre_full as the second chain) on a list
// of inputs, for the parity check against learned.twins.ibl (learned/parity/checks/ibl.py).
#include "lib/ibl.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_pre;
uniform sampler2D u_pre_full;
uniform sampler2D u_lut;
uniform sampler2D u_dominant;
uniform float u_levels;
layout(std430, binding = 0) readonly buffer In { float inv[]; };   // [n][6] dir, r, NoV, w
layout(std430, binding = 1) writeonly buffer Out { float outv[]; }; // [n][9] rgb, dfg, t, rgb
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 d = vec3(inv[6u * i], inv[6u * i + 1u], inv[6u * i + 2u]);
    float r = inv[6u * i + 3u];
    float NoV = inv[6u * i + 4u];
    vec3 s = ibl_specular_radiance(u_pre, d, r, u_levels);
    vec2 g = ibl_dfg(u_lut, NoV, r);
    float t = ibl_dominant_factor(u_dominant, NoV, r);
    vec3 m = ibl_specular_radiance_sun(u_pre, u_pre_full, d, r, u_levels, inv[6u * i + 5u]);
    outv[9u * i] = s.x; outv[9u * i + 1u] = s.y; outv[9u * i + 2u] = s.z;
    outv[9u * i + 3u] = g.x; outv[9u * i + 4u] = g.y; outv[9u * i + 5u] = t;
    outv[9u * i + 6u] = m.x; outv[9u * i + 7u] = m.y; outv[9u * i + 8u] = m.z;
}

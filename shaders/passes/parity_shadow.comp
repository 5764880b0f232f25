// parity_shadow.comp - lib/shadow.glsl's map lookups (shadow_depth_at, shadow_blocker_depth,
// shadow_pcf, shadow_visibility) on a list of inputs, for the parity check against
// learned.twins.shadow (learned/parity/checks/shadow.py).
#include "lib/shadow.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_map;
uniform float u_depth_range;
uniform float u_extent;
// [n][9]: s (u, v, depth), radius (uv: search and PCF), angle, phi, m (light-space normal)
layout(std430, binding = 0) readonly buffer In { float inv[]; };
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [n][6]
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 s = vec3(inv[9u * i], inv[9u * i + 1u], inv[9u * i + 2u]);
    float radius = inv[9u * i + 3u];
    float angle = inv[9u * i + 4u];
    float phi = inv[9u * i + 5u];
    vec2 dz = shadow_depth_slope(vec3(inv[9u * i + 6u], inv[9u * i + 7u], inv[9u * i + 8u]));
    outv[6u * i] = shadow_depth_at(u_map, s.xy);
    outv[6u * i + 1u] = shadow_blocker_depth(u_map, s.xy, s.z, dz, radius, phi);
    outv[6u * i + 2u] = shadow_pcf(u_map, s.xy, s.z, dz, radius, phi);
    outv[6u * i + 3u] = shadow_visibility(u_map, s, dz, angle, u_depth_range, u_extent, phi);
    outv[6u * i + 4u] = dz.x;
    outv[6u * i + 5u] = dz.y;
}

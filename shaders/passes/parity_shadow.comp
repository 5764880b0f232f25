// parity_shadow.comp - lib/shadow.glsl's map lookups (shadow_depth_at, shadow_blocker_depth,
// shadow_pcf, shadow_visibility) on a list of inputs, for the parity check against
// learned.twins.shadow (learned/parity/checks/shadow.py).
#include "lib/shadow.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_map;
uniform float u_depth_range;
uniform float u_extent;
// [n][7]: s (u, v, depth), radius (uv: search and PCF), angle, phi, unused
layout(std430, binding = 0) readonly buffer In { float inv[]; };
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [n][4]
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 s = vec3(inv[7u * i], inv[7u * i + 1u], inv[7u * i + 2u]);
    float radius = inv[7u * i + 3u];
    float angle = inv[7u * i + 4u];
    float phi = inv[7u * i + 5u];
    outv[4u * i] = shadow_depth_at(u_map, s.xy);
    outv[4u * i + 1u] = shadow_blocker_depth(u_map, s.xy, s.z, radius, phi);
    outv[4u * i + 2u] = shadow_pcf(u_map, s.xy, s.z, radius, phi);
    outv[4u * i + 3u] = shadow_visibility(u_map, s, angle, u_depth_range, u_extent, phi);
}

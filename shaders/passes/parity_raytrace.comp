// parity_raytrace.comp - passes/raytrace.glsl's bvh_closest_hit and bvh_any_hit on a list of rays,
// for the parity check against learned.twins.bvh (learned/parity/checks/raytrace.py) and the BVH
// tests (tests/viewer/test_raytrace.py).
#include "passes/raytrace.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [n][7] o, d, t_max
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [n][5] t, tri, b, any
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 o = vec3(inv[7u * i], inv[7u * i + 1u], inv[7u * i + 2u]);
    vec3 d = vec3(inv[7u * i + 3u], inv[7u * i + 4u], inv[7u * i + 5u]);
    float t_max = inv[7u * i + 6u];
    RayHit h = bvh_closest_hit(o, d, t_max);
    outv[5u * i] = h.t;
    outv[5u * i + 1u] = float(h.triangle);
    outv[5u * i + 2u] = h.b.x;
    outv[5u * i + 3u] = h.b.y;
    outv[5u * i + 4u] = bvh_any_hit(o, d, t_max) ? 1.0 : 0.0;
}

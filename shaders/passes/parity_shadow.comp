// parity_shadow.comp - lib/shadow.glsl's map lookups (shadow_sample, shadow_blocker_depth,
// shadow_pcf, shadow_visibility, shadow_pcss) on a list of inputs, for the parity check against
// learned.twins.shadow (learned/parity/checks/shadow.py). u_lens: the map's kind and lens
// (shadow_penumbra_uv); a cube map is an atlas 3 x 2 faces, a cascaded map one of 2 x 2 tiles
// (face -2 - k: tile k).
#define SHADOW_CASCADE_MAPS 1
#include "lib/shadow.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_map;
uniform float u_depth_range;
uniform float u_extent;
uniform vec4 u_lens;
// [n][13]: s (u, v, depth), radius (uv: search and PCF), angle, phi, m (light-space normal),
// face (-1: a 2D map; below -1: a cascade tile), plane (shadow_receiver_depth)
layout(std430, binding = 0) readonly buffer In { float inv[]; };
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [n][8]
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    uint k = 13u * i;
    vec3 s = vec3(inv[k], inv[k + 1u], inv[k + 2u]);
    float radius = inv[k + 3u];
    float angle = inv[k + 4u];
    float phi = inv[k + 5u];
    vec2 dz = shadow_depth_slope(vec3(inv[k + 6u], inv[k + 7u], inv[k + 8u]));
    int face = int(inv[k + 9u]);
    vec3 plane = vec3(inv[k + 10u], inv[k + 11u], inv[k + 12u]);
    bool umbra;
    uint o = 8u * i;
    outv[o] = shadow_sample(u_map, s.xy, face);
    vec2 dir = vec2(cos(phi), sin(phi));
    float size = shadow_map_size(u_map, face);
    outv[o + 1u] = shadow_blocker_depth(u_map, s.xy, plane, radius, dir, size, u_lens, face,
                                        true, umbra);
    outv[o + 2u] = umbra ? 1.0 : 0.0;
    outv[o + 3u] = shadow_pcf(u_map, s.xy, plane, radius, dir, size, u_lens, face, true);
    outv[o + 4u] = face < 0 ? shadow_visibility(u_map, s, dz, angle, u_depth_range, u_extent, phi)
                            : 0.0;
    outv[o + 5u] = shadow_pcss(u_map, s, plane, u_lens, phi, face, true);
    outv[o + 6u] = dz.x;
    outv[o + 7u] = dz.y;
}

// shadow.glsl - shadow-map lookups: receiver bias, percentage-closer soft shadows (PCSS: blocker
// search, then a PCF kernel whose radius follows the light's size). The map stores, per texel, the
// normalised light-space depth (0 nearest the light, 1 farthest) of the nearest occluder, in an
// R32F texture read with texelFetch (nearest texel, clamped to the map); 1 where nothing is.
// No uniforms, no main. Twins: learned/twins/shadow.py.
#include "lib/common.glsl"

#define SHADOW_SEARCH_SAMPLES 16
#define SHADOW_PCF_SAMPLES 32

// Sample i of n on a unit disk (Vogel's golden-angle spiral), rotated by phi: evenly spread for
// any n, and a per-pixel phi turns banding into noise.
vec2 vogel_disk(int i, int n, float phi) {
    float r = sqrt((float(i) + 0.5) / float(n));
    float theta = float(i) * 2.39996323 + phi;
    return r * vec2(cos(theta), sin(theta));
}

// A pixel's rotation of the shadow filters' sample disk: interleaved gradient noise (Jimenez
// 2014) of its fragment coordinates, in [0, 2 pi): the filter's pattern becomes noise, not bands.
float shadow_phi(vec2 frag_coord) {
    return 6.28318531 * fract(52.9829189 * fract(dot(frag_coord, vec2(0.06711056, 0.00583715))));
}

// The receiver's world position moved off its surface before the lookup (normal-offset bias):
// along the normal by 1.5 texels, more as the light grazes the surface (up to 3 more at
// NoL -> 0), so a lit plane never shadows itself at any incidence.
vec3 shadow_receiver(vec3 p_ws, vec3 n_ws, vec3 l_ws, float texel_world) {
    float NoL = clamp(dot(n_ws, l_ws), 0.0, 1.0);
    return p_ws + n_ws * texel_world * (1.5 + 3.0 * (1.0 - NoL));
}

// The depth stored at uv (nearest texel, clamped to the map's edge).
float shadow_depth_at(sampler2D map, vec2 uv) {
    ivec2 size = textureSize(map, 0);
    ivec2 t = clamp(ivec2(floor(uv * vec2(size))), ivec2(0), size - 1);
    return texelFetch(map, t, 0).r;
}

// The receiver's depth gradient in the map (receiver-plane depth bias): a planar receiver of
// light-space normal m (the normal through the inverse transpose of the world -> map matrix)
// has depth z + dot(shadow_depth_slope(m), offset) at a uv offset, so samples of a filter
// footprint compare against the receiver's own plane, not its centre's depth (a slanted receiver
// would otherwise shadow itself under a wide kernel). Clamped to 4 depth units per uv unit where
// the light grazes the surface.
vec2 shadow_depth_slope(vec3 m) {
    vec2 g = -m.xy / (abs(m.z) > 1e-6 ? m.z : 1e-6);
    float len_g = length(g);
    return len_g > 4.0 ? g * (4.0 / len_g) : g;
}

// PCSS step 1: mean depth of the occluders in front of the receiver (depth z at uv, plane slope
// dz) within radius search_uv of uv; -1 where none is (fully lit).
float shadow_blocker_depth(sampler2D map, vec2 uv, float z, vec2 dz, float search_uv,
                           float phi) {
    float sum = 0.0;
    float count = 0.0;
    for (int i = 0; i < SHADOW_SEARCH_SAMPLES; ++i) {
        vec2 o = vogel_disk(i, SHADOW_SEARCH_SAMPLES, phi) * search_uv;
        float d = shadow_depth_at(map, uv + o);
        if (d < z + dot(dz, o)) {
            sum += d;
            count += 1.0;
        }
    }
    return count > 0.0 ? sum / count : -1.0;
}

// Percentage-closer filter: the fraction of SHADOW_PCF_SAMPLES disk samples of radius r_uv around
// uv whose stored depth does not occlude the receiver's plane (depth z at uv, slope dz).
float shadow_pcf(sampler2D map, vec2 uv, float z, vec2 dz, float r_uv, float phi) {
    float lit = 0.0;
    for (int i = 0; i < SHADOW_PCF_SAMPLES; ++i) {
        vec2 o = vogel_disk(i, SHADOW_PCF_SAMPLES, phi) * r_uv;
        lit += shadow_depth_at(map, uv + o) >= z + dot(dz, o) ? 1.0 : 0.0;
    }
    return lit / float(SHADOW_PCF_SAMPLES);
}

// Visibility of a directional light of angular radius `angle` (radians) at the light-space point
// s = (u, v, depth) of a receiver (after shadow_receiver) whose plane has depth slope dz
// (shadow_depth_slope): PCSS with the penumbra of a disk light
// seen past an occluder, w = (z_receiver - z_blocker) * depth_range * 2 tan(angle), in uv units of
// a map `extent` world units wide; at least one texel wide (a hard shadow is still filtered over a
// texel so it does not alias). Outside the map: lit.
float shadow_visibility(sampler2D map, vec3 s, vec2 dz, float angle, float depth_range,
                        float extent, float phi) {
    if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return 1.0;
    float texel_uv = 1.0 / float(textureSize(map, 0).x);
    float t = tan(clamp(angle, 0.0, 0.3));
    // an occluder as far in front as the light's side of the map casts a penumbra of half-width
    // s.z depth_range tan(angle): no farther occluder can reach the receiver
    float search = max(s.z * depth_range * t / extent, 2.0 * texel_uv);
    float blocker = shadow_blocker_depth(map, s.xy, s.z, dz, search, phi);
    if (blocker < 0.0) return 1.0;
    float penumbra = (s.z - blocker) * depth_range * 2.0 * t / extent;
    return shadow_pcf(map, s.xy, s.z, dz, max(penumbra * 0.5, texel_uv), phi);
}

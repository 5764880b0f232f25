// shadow.frag - the depth of the nearest occluder, normalised in the light's frame (0 nearest
// the light), into the map's depth texture (the depth test keeps the nearest; the map has no
// colour attachment: viewer/graph/resources.py ShadowTarget). Meshes write v_depth (RADIAL: the
// distance from the light, (|p - light| - near) / range); splats (SPLAT) discard where a
// Gaussian's opacity falls below SPLAT_SHADOW_ALPHA and write the Gaussian's mean depth along the
// ray. An orthographic map's meshes (WRITE_DEPTH 0) keep the rasterised depth, the same linear
// depth: no gl_FragDepth write and nothing else, so the rasteriser tests depth early and the
// fragment stage does no work.
#ifndef SPLAT
#define SPLAT 0
#endif
#ifndef RADIAL
#define RADIAL 0
#endif
#ifndef WRITE_DEPTH
#define WRITE_DEPTH 1  // 0: the rasterised depth is the map's (orthographic meshes: exact)
#endif
#define SPLAT_SHADOW_ALPHA 0.5
in float v_depth;
#if SPLAT
in vec2 v_offset;       // from the splat's centre, map texels
flat in vec3 v_conic;   // inverse 2D covariance (a, b, c), texels^-2
flat in float v_opacity;
#endif
#if RADIAL
in vec3 v_from_light;
uniform vec2 u_near_range;  // world distance of depth 0, world distance from depth 0 to 1
#endif

void main() {
#if WRITE_DEPTH || SPLAT
    float depth = v_depth;
#endif
#if SPLAT
    vec2 d = v_offset;
    float power = -0.5 * (v_conic.x * d.x * d.x + 2.0 * v_conic.y * d.x * d.y
                          + v_conic.z * d.y * d.y);
    if (v_opacity * exp(power) < SPLAT_SHADOW_ALPHA) discard;
#endif
#if RADIAL
    depth = (length(v_from_light) - u_near_range.x) / u_near_range.y;
#endif
#if WRITE_DEPTH
    gl_FragDepth = clamp(depth, 0.0, 1.0);
#endif
}

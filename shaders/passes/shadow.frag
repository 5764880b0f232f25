// shadow.frag - writes the normalised light-space depth of the nearest occluder (R32F; the
// depth test keeps the nearest). Meshes pass v_depth; splats (SPLAT) discard where a Gaussian's
// opacity falls below SPLAT_SHADOW_ALPHA and write the Gaussian's mean depth along the ray.
#ifndef SPLAT
#define SPLAT 0
#endif
#define SPLAT_SHADOW_ALPHA 0.5
in float v_depth;
#if SPLAT
in vec2 v_offset;       // from the splat's centre, map texels
flat in vec3 v_conic;   // inverse 2D covariance (a, b, c), texels^-2
flat in float v_opacity;
#endif
layout(location = 0) out float o_depth;

void main() {
#if SPLAT
    vec2 d = v_offset;
    float power = -0.5 * (v_conic.x * d.x * d.x + 2.0 * v_conic.y * d.x * d.y
                          + v_conic.z * d.y * d.y);
    if (v_opacity * exp(power) < SPLAT_SHADOW_ALPHA) discard;
#endif
    o_depth = v_depth;
    gl_FragDepth = v_depth;
}

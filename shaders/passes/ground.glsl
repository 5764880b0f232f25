// ground.glsl - the shadow-catcher ground in the lighting passes: which pixels are the catcher
// (the G-buffer's +Y-facing surface on the catcher's plane) and their radiance
// (lib/ground.glsl). Pass-level chunk (has uniforms), included by passes/deferred.glsl, whose
// write_radiance passes every shaded pixel through ground_catcher; passes/ssao.frag adds no
// screen-space bounce on_ground_catcher. Uniforms set by
// viewer/passes/ground.py; u_ground_center.w = 0 (a scene without a catcher) changes nothing.
#include "lib/ground.glsl"

uniform vec4 u_ground_center;      // xyz: the catcher's centre - the camera's position (world);
                                   // w: the fade's end radius (world units), 0 = no catcher
uniform vec4 u_ground_unshadowed;  // rgb: the catcher's radiance with nothing occluding it;
                                   // w: the fade's start radius

// A G-buffer pixel's position relative to the catcher's centre (world): the view ray through
// frag_coord to the stored depth.
vec3 ground_offset(GBuffer g, vec2 frag_coord) {
    vec2 ndc = frag_coord / u_resolution * 2.0 - 1.0;
    return u_camera_to_world * vec3(ndc * u_tan_half_fov, -1.0) * g.depth - u_ground_center.xyz;
}

// Whether a G-buffer pixel is the catcher: a +Y-facing surface on its plane, to the depth's
// precision (a G-buffer may store it as a half float: 2^-11 relative); any other +Y-facing
// surface is the object's own. False in a scene without a catcher.
bool on_ground_catcher(GBuffer g, vec2 frag_coord) {
    if (!(u_ground_center.w > 0.0) || g.alpha <= 0.0 || g.normal.y < 0.999) {
        return false;
    }
    return abs(ground_offset(g, frag_coord).y) <= 4e-3 * g.depth;
}

// The lighting passes' radiance at this fragment: the catcher's (lib/ground.glsl) on its
// pixels, `shaded` elsewhere.
vec3 ground_catcher(vec3 shaded, vec3 background) {
    if (!(u_ground_center.w > 0.0)) {
        return shaded;
    }
    GBuffer g = gbuffer_load(ivec2(gl_FragCoord.xy));
    if (!on_ground_catcher(g, gl_FragCoord.xy)) {
        return shaded;
    }
    float r = length(ground_offset(g, gl_FragCoord.xy).xz);
    float fade = ground_fade(r, u_ground_unshadowed.w, u_ground_center.w);
    return ground_catcher_radiance(shaded, u_ground_unshadowed.rgb, background, fade);
}

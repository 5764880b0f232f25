// ground.glsl - the shadow-catcher ground in the lighting passes: which pixels are the catcher
// (the G-buffer's +Y-facing surface on the catcher's plane) and their radiance
// (lib/ground.glsl). Pass-level chunk (has uniforms), included by passes/deferred.glsl, whose
// write_radiance passes every shaded pixel through ground_catcher. Uniforms set by
// viewer/passes/ground.py; u_ground_center.w = 0 (a scene without a catcher) changes nothing.
#include "lib/ground.glsl"

uniform vec4 u_ground_center;      // xyz: the catcher's centre - the camera's position (world);
                                   // w: the fade's end radius (world units), 0 = no catcher
uniform vec4 u_ground_unshadowed;  // rgb: the catcher's radiance with nothing occluding it;
                                   // w: the fade's start radius

vec3 ground_catcher(vec3 shaded, vec3 background) {
    if (!(u_ground_center.w > 0.0)) {
        return shaded;
    }
    GBuffer g = gbuffer_load(ivec2(gl_FragCoord.xy));
    if (g.alpha <= 0.0 || g.normal.y < 0.999) {
        return shaded;
    }
    vec2 ndc = gl_FragCoord.xy / u_resolution * 2.0 - 1.0;
    vec3 rel = u_camera_to_world * vec3(ndc * u_tan_half_fov, -1.0) * g.depth - u_ground_center.xyz;
    // on the catcher's plane to the depth's precision (a G-buffer may store it as a half float:
    // 2^-11 relative), else a +Y-facing surface of the object's own
    if (abs(rel.y) > 4e-3 * g.depth) {
        return shaded;
    }
    float fade = ground_fade(length(rel.xz), u_ground_unshadowed.w, u_ground_center.w);
    return ground_catcher_radiance(shaded, u_ground_unshadowed.rgb, background, fade);
}

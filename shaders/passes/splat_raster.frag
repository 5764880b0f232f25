// splat_raster.frag - a splat's fragment: alpha from the Mahalanobis distance at the pixel centre,
// written premultiplied to four accumulation targets. Blending (ONE, ONE_MINUS_SRC_ALPHA) back to
// front gives sum_i T_i alpha_i x_i in rgb and the coverage 1 - prod(1 - alpha_i) in a.
#include "lib/splat.glsl"

flat in vec2 v_centre;
flat in vec3 v_conic;
flat in float v_opacity;
flat in vec3 v_color;
flat in vec3 v_albedo;
flat in vec3 v_normal_ws;
flat in vec3 v_rmd;

layout(location = 0) out vec4 o_color;    // baked colour
layout(location = 1) out vec4 o_albedo;
layout(location = 2) out vec4 o_normal;   // world space
layout(location = 3) out vec4 o_rmd;      // roughness, metallic, depth

void main() {
    float a = splat_alpha(v_opacity, splat_mahalanobis2(gl_FragCoord.xy - v_centre, v_conic));
    if (a <= 0.0) {
        discard;
    }
    o_color = vec4(v_color * a, a);
    o_albedo = vec4(v_albedo * a, a);
    o_normal = vec4(v_normal_ws * a, a);
    o_rmd = vec4(v_rmd * a, a);
}

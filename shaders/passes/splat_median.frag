// splat_median.frag - the passes of the median-depth search (lib/splat.glsl, "median depth"),
// drawn with splat_raster.vert in the same back-to-front order and depth test as splat_raster:
//   SPLAT_MEDIAN_PASS 0: the range of contributing depths: (d, d, d, d) blended with
//                        (MIN, MAX): r = nearest, a = farthest.
//   SPLAT_MEDIAN_PASS 1: one search level: out k (k = 1..16) = 1 - alpha where the splat's
//                        depth <= threshold k of the pixel's range, else 1; blended (ZERO,
//                        SRC_COLOR), the targets hold the transmittance at each threshold.
//   SPLAT_MEDIAN_PASS 2: the answer: the nearest depth in the final range, blended with MIN.
#include "lib/splat.glsl"

flat in vec2 v_centre;
flat in vec3 v_conic;
flat in float v_opacity;
flat in vec3 v_rmd;  // roughness, metallic, depth

uniform sampler2D u_state;  // (lo, hi, t_target, 0) per pixel (passes 1 and 2)

#if SPLAT_MEDIAN_PASS == 1
layout(location = 0) out vec4 o_t0;
layout(location = 1) out vec4 o_t1;
layout(location = 2) out vec4 o_t2;
layout(location = 3) out vec4 o_t3;
#else
layout(location = 0) out vec4 o_value;
#endif

void main() {
    float a = splat_alpha(v_opacity, splat_mahalanobis2(gl_FragCoord.xy - v_centre, v_conic));
    if (a <= 0.0) {
        discard;
    }
    float depth = v_rmd.z;
#if SPLAT_MEDIAN_PASS == 0
    o_value = vec4(depth);
#else
    vec2 range = texelFetch(u_state, ivec2(gl_FragCoord.xy), 0).xy;
#if SPLAT_MEDIAN_PASS == 1
    float t[16];
    for (int k = 1; k <= 16; ++k) {
        t[k - 1] = depth <= splat_depth_threshold(range, k) ? 1.0 - a : 1.0;
    }
    o_t0 = vec4(t[0], t[1], t[2], t[3]);
    o_t1 = vec4(t[4], t[5], t[6], t[7]);
    o_t2 = vec4(t[8], t[9], t[10], t[11]);
    o_t3 = vec4(t[12], t[13], t[14], t[15]);
#else
    if (depth < range.x || depth > range.y) {
        discard;
    }
    o_value = vec4(depth);
#endif
#endif
}

// rt_filter.frag - one iteration of the real-time tier's edge-avoiding a-trous filter over the
// three targets of passes/rt_light.frag (after temporal accumulation): a 5 x 5 B3-spline kernel
// with holes of u_step pixels, each tap weighted by lib/denoise.glsl's depth and normal
// edge-stopping function, so light does not leak across silhouettes or creases. Iterations with
// steps 1, 2, 4 cover a 29-pixel footprint (viewer/passes/rt_light.py FILTER_STEPS). Target 1's
// alpha (the sun's traced visibility) passes through unfiltered. At RT_SCALE = k > 1 it runs on
// the low-resolution targets, each texel standing for its block's sample pixel
// (passes/ssao_upsample.glsl ssao_sample_pixel), a step of one texel k pixels of the frame.
#include "passes/deferred.glsl"
#include "lib/denoise.glsl"
#include "lib/shading.glsl"
#ifndef RT_SCALE
#define RT_SCALE 1
#endif
#define SSAO_SCALE RT_SCALE
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"

uniform sampler2D u_in0;
uniform sampler2D u_in1;
uniform sampler2D u_in2;
uniform int u_step;
uniform float u_sigma_z;  // relative depth difference per pixel of step that halves a weight
uniform float u_sigma_n;  // the normals' agreement exponent
layout(location = 1) out vec4 o_1;
layout(location = 2) out vec4 o_2;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(u_in0, 0);
    GBuffer g = gbuffer_load(ssao_sample_pixel(pixel));
    vec4 c0 = texelFetch(u_in0, pixel, 0);
    vec4 c1 = texelFetch(u_in1, pixel, 0);
    vec4 c2 = texelFetch(u_in2, pixel, 0);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
        o_radiance = c0; o_1 = c1; o_2 = c2;
        return;
    }
    vec4 s0 = vec4(0.0), s1 = vec4(0.0), s2 = vec4(0.0);
    float total = 0.0;
    for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
            ivec2 q = pixel + ivec2(i, j) * u_step;
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            GBuffer gq = gbuffer_load(ssao_sample_pixel(q));
            float w = atrous_kernel(float(i)) * atrous_kernel(float(j));
            if (i != 0 || j != 0) {
                if (gq.alpha <= 0.0) continue;
                w *= atrous_edge_weight(g.depth, gq.depth, g.normal, gq.normal,
                                        float(u_step * RT_SCALE) * length(vec2(i, j)),
                                        u_sigma_z, u_sigma_n);
            }
            s0 += w * texelFetch(u_in0, q, 0);
            s1 += w * texelFetch(u_in1, q, 0);
            s2 += w * texelFetch(u_in2, q, 0);
            total += w;
        }
    }
    o_radiance = s0 / total;
    o_1 = vec4(s1.rgb / total, c1.a);  // the sun's visibility keeps its edges (not filtered)
    o_2 = s2 / total;
}

// rt_upsample.frag - the real-time tier's filtered targets at reduced scale (RT_SCALE = k > 1,
// render.ray_scale: passes/rt_light.frag traced one pixel in k x k) brought to full resolution by
// SSAO's joint bilateral upsampling (passes/ssao_upsample.glsl, weights lib/ssao.glsl), for the
// lighting pass to read as at full scale; on the background what rt_light.frag writes there.
// With RT_SUN the sun's visibility (target 1's alpha) is not upsampled: it is u_sun's, traced
// and accumulated for every pixel (rt_light.frag with RT_SUN_PASS), so its shadow keeps its edge.
// Defines: RT_SCALE, RT_SUN. Twin: learned.twins.ssao.ssao_upsample (per target).
#include "passes/deferred.glsl"
#include "lib/shading.glsl"
#define SSAO_SCALE RT_SCALE
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"

uniform sampler2D u_low0;
uniform sampler2D u_low1;
uniform sampler2D u_low2;
#ifndef RT_SUN
#define RT_SUN 0
#endif
#if RT_SUN
uniform sampler2D u_sun;  // r: the sun's visibility at full resolution, accumulated
#endif
layout(location = 1) out vec4 o_1;
layout(location = 2) out vec4 o_2;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec4 none = vec4(0.0, 0.0, 0.0, 1.0);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
        o_radiance = vec4(1.0); o_1 = none; o_2 = none;
        return;
    }
    o_radiance = ssao_upsample(u_low0, pixel, g, vec4(1.0));
    o_1 = ssao_upsample(u_low1, pixel, g, none);
    o_2 = ssao_upsample(u_low2, pixel, g, none);
#if RT_SUN
    o_1.a = texelFetch(u_sun, pixel, 0).r;
#endif
}

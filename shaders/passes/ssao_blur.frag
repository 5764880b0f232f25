// ssao_blur.frag - the occlusion O(x) (passes/ssao.frag, brought to full resolution by
// passes/ssao_upsample.frag at reduced scale) through the bilateral blur of
// passes/ssao_upsample.glsl (ssao_blur) against its per-pixel noise (render.ssao_blur). With
// SSAO_ENV_VIS the g channel, the environment's visibility S(x) a student reads, is passed
// through as the occlusion pass wrote it (the students are trained on it unfiltered). 1 on the
// background, as the occlusion pass writes there.
// Defines: SSAO_ENV_VIS (0/1). Twin: learned.twins.ssao.ssao_blur.
#include "passes/deferred.glsl"
#include "lib/shading.glsl"
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"

uniform sampler2D u_ao;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
        o_radiance = vec4(1.0);
        return;
    }
    vec4 blurred = ssao_blur(u_ao, pixel, g);
#if SSAO_ENV_VIS
    blurred.g = texelFetch(u_ao, pixel, 0).g;
#endif
    o_radiance = blurred;
}

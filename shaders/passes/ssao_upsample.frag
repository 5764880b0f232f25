// ssao_upsample.frag - the occlusion pass's result at reduced scale (passes/ssao.frag with
// SSAO_SCALE = k > 1: O(x) and the environment's visibility S(x) for one pixel in k x k) brought
// to full resolution by joint bilateral upsampling (passes/ssao_upsample.glsl), for the lighting
// passes to read as at full scale. 1 on the background, as the occlusion pass writes there.
// Defines: SSAO_SCALE. Twin: learned.twins.ssao.ssao_upsample.
#include "passes/deferred.glsl"
#include "lib/shading.glsl"
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"

uniform sampler2D u_low;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
        o_radiance = vec4(1.0);
        return;
    }
    o_radiance = ssao_upsample(u_low, pixel, g, vec4(1.0));
}

// tonemap.frag - exposure, tone mapping and sRGB encoding: linear radiance -> display pixels.
// Defines: TONEMAP (0 none, 1 ACES fitted, 2 Reinhard, 3 Khronos PBR Neutral, 4 AgX).
#include "lib/tonemap.glsl"

uniform sampler2D u_radiance;
uniform float u_exposure;  // EV stops
in vec2 v_uv;
layout(location = 0) out vec4 o_color;

void main() {
    vec4 radiance = texelFetch(u_radiance, ivec2(gl_FragCoord.xy), 0);
    vec3 c = apply_exposure(radiance.rgb, u_exposure);
#if TONEMAP == 1
    c = tonemap_aces_fitted(c);
#elif TONEMAP == 2
    c = tonemap_reinhard(c);
#elif TONEMAP == 3
    c = tonemap_pbr_neutral(c);
#elif TONEMAP == 4
    c = tonemap_agx(c);
#endif
    o_color = vec4(linear_to_srgb(c), radiance.a);
}

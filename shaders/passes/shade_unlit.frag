// shade_unlit.frag - the surface's own colour without lighting: albedo, or the baked colour of
// splats when the G-buffer carries one (GBUFFER_HAS_COLOR). For inspection.
// Defines: BACKGROUND_ENVIRONMENT (0/1).
#include "passes/deferred.glsl"

void main() {
    GBuffer g = gbuffer_load(ivec2(gl_FragCoord.xy));
    vec3 background = background_radiance(view_ray_ws(gl_FragCoord.xy));
#if GBUFFER_HAS_COLOR
    // the colour channel is premultiplied by coverage
    vec3 c = g.alpha > 0.0 ? g.color / g.alpha : vec3(0.0);
#else
    vec3 c = g.albedo;
#endif
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

// splat_median_update.frag - the per-pixel state of the median-depth search (lib/splat.glsl):
//   SPLAT_MEDIAN_INIT 1: (lo, hi) = the range pass's (nearest, farthest) contributing depth,
//                        t_target = 1 - splat_median_target(coverage, alpha of what lies under).
//   SPLAT_MEDIAN_INIT 0: one level: (lo, hi) narrowed by splat_depth_refine.
#include "lib/splat.glsl"
#if SPLAT_MEDIAN_INIT
#define GBUFFER_READ
#include "generated/gbuffer.glsl"
uniform sampler2D u_range;    // (nearest, -, -, farthest)
uniform sampler2D u_accum0;   // (sum T a c, coverage A)
#else
uniform sampler2D u_state;
uniform sampler2D u_t0;
uniform sampler2D u_t1;
uniform sampler2D u_t2;
uniform sampler2D u_t3;
#endif

out vec4 o_state;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
#if SPLAT_MEDIAN_INIT
    vec4 range = texelFetch(u_range, px, 0);
    float coverage = texelFetch(u_accum0, px, 0).a;
    float target = splat_median_target(coverage, gbuffer_load(px).alpha);
    o_state = vec4(range.x, range.w, 1.0 - target, 0.0);
#else
    vec4 s = texelFetch(u_state, px, 0);
    vec2 r = splat_depth_refine(s.xy, s.z, texelFetch(u_t0, px, 0), texelFetch(u_t1, px, 0),
                                texelFetch(u_t2, px, 0), texelFetch(u_t3, px, 0));
    o_state = vec4(r, s.z, 0.0);
#endif
}

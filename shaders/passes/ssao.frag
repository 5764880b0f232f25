// ssao.frag - screen-space ambient occlusion and one-bounce indirect light from the G-buffer
// (thesis sec. 6.4, eqs. 6.19-6.22). For every covered pixel, u_rays cosine-weighted directions
// around the normal are marched in view space in u_steps steps up to u_radius (world units); a
// step is a hit when its depth lies behind the stored surface depth by less than u_thickness
// (eq. 6.20, lib/ssao.glsl). With cosine sampling, eq. 6.19 is estimated by
//   O(x) = 1 - (1/R) sum_k V_k.
// SSAO_INDIRECT = 0 writes O to all four channels (read by passes/deferred.glsl's
// ambient_occlusion). SSAO_INDIRECT = 1 adds eq. 6.22 to u_direct (the lighting pass's output,
// L_dir of eq. 6.18): the radiance arriving along a ray that hits pixel p is approximated by the
// direct radiance stored at p (eq. 6.21; exact for diffuse hit points), so
// L_ind = (1 - m) a (1/R) sum_k V_k L_dir(p_k).
// Directions and step offsets come from lib/mc.glsl's sequence (dimension pairs 2, 3) for u_seed,
// so both modes march the same rays. SSAO_HITS = T > 0 marches them once per frame: the occlusion
// pass also writes ray k's hit pixel (x | y << 16; SSAO_NO_HIT for a miss, for k >= u_rays and on
// pixels without a surface) to channel k % 4 of o_hits[k / 4] (RGBA32UI targets 1..T) for
// k < 4 T, and the indirect pass reads them from u_hits instead of marching: the same pixels of
// u_direct summed in the same order, so the light is the marching one's bit for bit. With
// SSAO_MARCH_REST it marches the rays k >= 4 T itself (u_rays beyond what the targets hold,
// viewer.passes.ssao.HIT_TARGETS_MAX); without SSAO_HITS, all of them.
// SSAO_ENV_VIS = 1 (occlusion mode) also writes, to the g channel, the screen-space visibility
// of the environment's light: S(x) = sum_k V_k max(n.l_k, 0) / sum_k max(n.l_k, 0) over the
// ENV_VIS_DIRS directions u_vis_dirs (environment frame; viewer.environment.sampling.power_directions: each
// carries an equal share of the environment's power, so a small bright sun gets most of them),
// each marched u_vis_steps steps up to u_vis_radius; 1 where no direction is above the horizon.
// It is the cast-shadow evidence (a sun shadow on a floor) that cosine-weighted SSAO averages away;
// the students with "vis" features read it (shade_neural.frag).
// SSAO_INDIRECT_FACTOR = 1 (indirect mode) scales L_ind by the r channel of u_indirect_factor, the
// factor a neural student with a learned indirect term wrote in the lighting pass
// (shade_neural.frag, NEURAL_STUDENT_INDIRECT): L = L_dir + f L_ind.
// SSAO_SCALE = k > 1 (render.ssao_scale) runs the marching at reduced scale: the pass draws a
// target of ceil(W / k) x ceil(H / k) texels, each marching from one full-resolution pixel of its
// k x k block (passes/ssao_upsample.glsl ssao_sample_pixel) through the full-resolution G-buffer,
// so rays and hits are those of that pixel at full scale. The occlusion mode's result is brought
// to full resolution by passes/ssao_upsample.frag. The indirect light is two passes: SSAO_GATHER
// = 1 (low resolution) writes the gathered mean E = (1/R) sum_k V_k L_dir(p_k), read from the
// occlusion pass's hits (in texel order) or marched, and the composite (SSAO_INDIRECT without
// SSAO_GATHER, full resolution) upsamples E jointly bilaterally (u_gathered) and adds
// (1 - m) a f E at each pixel with its own albedo, metalness and factor.
// Defines: SSAO_INDIRECT (0/1), SSAO_ENV_VIS (0/1), SSAO_INDIRECT_FACTOR (0/1), SSAO_HITS (0-7),
// SSAO_MARCH_REST (0/1, indirect mode), SSAO_SCALE (>= 1), SSAO_GATHER (0/1, indirect mode),
// SSAO_COMPOSITE (0/1, indirect mode: the composite half; default: at k > 1 without GATHER). Twin: learned.twins.ssao.ssao_pass (it marches in both
// modes: recorded hits change no result).
#include "passes/deferred.glsl"
#include "lib/shading.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"

#ifndef SSAO_GATHER
#define SSAO_GATHER 0
#endif
// the full-resolution half of the indirect light at reduced scale, or at scale 1 after the
// gathered E went through passes/ssao_blur.frag (render.indirect_blur: the pass sets
// SSAO_COMPOSITE 1): no rays, E upsampled (at k = 1 read at the pixel itself)
#ifndef SSAO_COMPOSITE
#define SSAO_COMPOSITE (SSAO_INDIRECT != 0 && SSAO_SCALE > 1 && SSAO_GATHER == 0)
#endif

uniform int u_rays;
uniform int u_steps;
uniform float u_radius;     // world units
uniform float u_thickness;  // delta of eq. 6.20, world units
uniform uint u_seed;
#if SSAO_INDIRECT
uniform sampler2D u_direct;
#endif
#if SSAO_COMPOSITE
uniform sampler2D u_gathered;  // the SSAO_GATHER pass's E (rgb), low resolution
#endif
#ifndef SSAO_INDIRECT_FACTOR
#define SSAO_INDIRECT_FACTOR 0
#endif
#if SSAO_INDIRECT_FACTOR
uniform sampler2D u_indirect_factor;
#endif
#ifndef SSAO_ENV_VIS
#define SSAO_ENV_VIS 0
#endif
#ifndef SSAO_HITS
#define SSAO_HITS 0
#endif
#ifndef SSAO_MARCH_REST
#define SSAO_MARCH_REST 0
#endif
#if SSAO_HITS
#define SSAO_NO_HIT 0xFFFFFFFFu  // pixel (65535, 65535): beyond any framebuffer
#if SSAO_INDIRECT
uniform usampler2D u_hits[SSAO_HITS];  // the occlusion pass's o_hits
#else
layout(location = 1) out uvec4 o_hits[SSAO_HITS];  // rays 4 t .. 4 t + 3 in target 1 + t
#endif
#endif
#if SSAO_ENV_VIS
#define ENV_VIS_DIRS 8
uniform vec3 u_vis_dirs[ENV_VIS_DIRS];  // environment frame, unit
uniform int u_vis_steps;
uniform float u_vis_radius;  // world units
#endif

// March from p_vs along the unit view-space direction w in `steps` steps up to `radius`, the
// first at jitter * radius / steps; true at the first step that lies behind the stored surface
// (eq. 6.20), with its pixel in hit. Stops (false) behind the camera or off screen: nothing known
// occludes there.
bool ssao_march(vec3 p_vs, vec3 w, float radius, int steps, float jitter, out ivec2 hit) {
    hit = ivec2(0);
    for (int j = 0; j < steps; ++j) {
        vec3 q = p_vs + w * (radius * (float(j) + jitter) / float(steps));
        vec3 f = view_to_frag(q, u_resolution, u_tan_half_fov);
        if (!(f.z > 0.0) || any(lessThan(f.xy, vec2(0.0))) || any(greaterThanEqual(f.xy, u_resolution))) {
            return false;
        }
        ivec2 hp = ivec2(floor(f.xy));
        GBuffer h = gbuffer_load(hp);
        if (h.alpha <= 0.0) continue;
        vec3 hp_vs = view_position(vec2(hp) + 0.5, u_resolution, h.depth, u_tan_half_fov);
        vec3 hn = h.normal;
        vec3 hn_vs = dot(hn, hn) > 1e-12 ? to_view(normalize(hn)) : vec3(0.0);
        float z_d = surface_depth_at(q, hp_vs, hn_vs, h.depth);
        if (ssao_occluded(f.z, z_d, u_thickness) > 0.5) {
            hit = hp;
            return true;
        }
    }
    return false;
}

#if SSAO_COMPOSITE
void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec4 direct = texelFetch(u_direct, pixel, 0);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
        o_radiance = direct;
        return;
    }
    vec3 indirect = (1.0 - saturate(g.metallic)) * g.albedo
                  * ssao_upsample(u_gathered, pixel, g, vec4(0.0)).rgb;
#if SSAO_INDIRECT_FACTOR
    indirect *= texelFetch(u_indirect_factor, pixel, 0).r;
#endif
    bool finite = !any(isnan(indirect)) && !any(isinf(indirect));
    finite = finite && !on_ground_catcher(g, vec2(pixel) + 0.5);  // no bounce on the catcher
    o_radiance = vec4(direct.rgb + (finite ? indirect * g.alpha : vec3(0.0)), direct.a);
}
#else
void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);  // this pass's own target texel (hits are stored per texel)
    ivec2 pixel = ssao_sample_pixel(texel);  // the G-buffer pixel it marches from (= texel at k = 1)
    vec2 frag = vec2(pixel) + 0.5;          // = gl_FragCoord.xy at k = 1
    GBuffer g = gbuffer_load(pixel);
#if SSAO_HITS && !SSAO_INDIRECT
    for (int t = 0; t < SSAO_HITS; ++t) o_hits[t] = uvec4(SSAO_NO_HIT);
#endif
#if SSAO_INDIRECT && !SSAO_GATHER
    vec4 direct = texelFetch(u_direct, pixel, 0);
#endif
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {
#if SSAO_GATHER
        o_radiance = vec4(0.0);
#elif SSAO_INDIRECT
        o_radiance = direct;
#else
        o_radiance = vec4(1.0);
#endif
        return;
    }
    vec3 d = view_ray_ws(frag);
    vec3 n_vs = to_view(shading_normal(g.normal, -d));
    vec3 p_vs = view_position(frag, u_resolution, g.depth, u_tan_half_fov);
    float hits = 0.0;
    vec3 gathered = vec3(0.0);
#if SSAO_HITS && SSAO_INDIRECT
    // the rays the occlusion pass marched: where each hit, in the order of k
    for (int t = 0; t < SSAO_HITS; ++t) {
        uvec4 codes = texelFetch(u_hits[t], texel, 0);
        for (int i = 0; i < 4; ++i) {
            uint code = codes[i];
            if (4 * t + i < u_rays && code != SSAO_NO_HIT) {
                hits += 1.0;
                ivec2 hp = ivec2(int(code & 0xFFFFu), int(code >> 16));
                gathered += texelFetch(u_direct, hp, 0).rgb;
            }
        }
    }
#endif
#if !(SSAO_HITS && SSAO_INDIRECT) || SSAO_MARCH_REST
    // every ray, or (indirect mode with hits) those beyond the hit targets; compiled only where it
    // runs: at 512^2 llvmpipe took 17 ms for the pass reading hits with this loop in it, running
    // no ray, and 9 ms without it
    for (int k = SSAO_INDIRECT * 4 * SSAO_HITS; k < u_rays; ++k) {
        vec2 u = mc_sample_2d(uint(pixel.x), uint(pixel.y), uint(k), u_seed, 2u);
        float jitter = 1.0 - mc_sample_2d(uint(pixel.x), uint(pixel.y), uint(k), u_seed, 3u).x;
        vec3 w = tangent_to_world(sample_cosine_hemisphere(u), n_vs);
        ivec2 hp;
        if (ssao_march(p_vs, w, u_radius, u_steps, jitter, hp)) {
            hits += 1.0;
#if SSAO_INDIRECT
            gathered += texelFetch(u_direct, hp, 0).rgb;
#elif SSAO_HITS
            if (k < 4 * SSAO_HITS) o_hits[k >> 2][k & 3] = uint(hp.x) | (uint(hp.y) << 16);
#endif
        }
    }
#endif
    float rays = float(max(u_rays, 1));
#if SSAO_GATHER
    o_radiance = vec4(gathered / rays, 1.0);
#elif SSAO_INDIRECT
    vec3 indirect = (1.0 - saturate(g.metallic)) * g.albedo * gathered / rays;
#if SSAO_INDIRECT_FACTOR
    indirect *= texelFetch(u_indirect_factor, pixel, 0).r;
#endif
    bool finite = !any(isnan(indirect)) && !any(isinf(indirect));
    finite = finite && !on_ground_catcher(g, vec2(pixel) + 0.5);  // no bounce on the catcher
    o_radiance = vec4(direct.rgb + (finite ? indirect * g.alpha : vec3(0.0)), direct.a);
#else
    float visible = 1.0 - hits / rays;
#if SSAO_ENV_VIS
    float lit = 0.0;
    float total = 0.0;
    for (int k = 0; k < ENV_VIS_DIRS; ++k) {
        vec3 l_vs = to_view(rotate_y(u_vis_dirs[k], u_env_rotation));
        float c = max(dot(n_vs, l_vs), 0.0);
        if (c > 0.0) {
            float jitter = 1.0 - mc_sample_2d(uint(pixel.x), uint(pixel.y), uint(k), u_seed, 4u).x;
            ivec2 hp;
            total += c;
            lit += ssao_march(p_vs, l_vs, u_vis_radius, u_vis_steps, jitter, hp) ? 0.0 : c;
        }
    }
    o_radiance = vec4(visible, total > 0.0 ? lit / total : 1.0, visible, visible);
#else
    o_radiance = vec4(visible);
#endif
#endif
}
#endif

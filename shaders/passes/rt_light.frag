// rt_light.frag - the real-time tier's rays (viewer/passes/rt_light.py): from each G-buffer
// surface, u_rt_rays cosine-distributed rays and one ray drawn from the specular lobe (GGX VNDF)
// against the scene's triangles (passes/raytrace.glsl), for the ratio estimator of visibility
// (Heitz et al. 2018, "Combining Analytic Direct Illumination and Stochastic Shadows"): the
// shading pass keeps its noise-free environment terms (the irradiance map, the prefiltered chain)
// and multiplies them by the denoised ratio of the environment's light the rays see to all of it
// along the same rays, then adds the light the rays that hit something bring back (one bounce).
// The environment along a ray is the prefiltered chain (the one the shading pass reads: without
// the compact lights its SUN_LIGHT shades analytically), blurred to the lobe's roughness. The
// diffuse ratio draws its directions two ways, combined by the balance heuristic (Veach 1997):
// u_rt_rays cosine-distributed rays, whose hits also bring the bounce back, and one ray drawn
// from the environment's own distribution (lib/env_sampling.glsl), so a small bright lamp that
// the cosine rays rarely meet still casts its shadow. A hit surface's light is its
// Lambertian response to the irradiance map, the environment's sun and the scene's lights (a
// shadow ray each), plus its emission.
// Outputs (RGBA32F each, cosine- or lobe-weighted means over this frame's rays):
//   0: (diffuse seen, diffuse all, specular seen, specular all): luminances
//   1: (light the diffuse rays' hits bring back, rgb; the sun's visibility with RT_SUN, else 1)
//   2: the specular lobe's: for a lobe narrower than RT_SPECULAR_MC_ROUGHNESS the light its
//      ray's hit brings back (rgb; 1), for a wider one the weighted light along the ray, hit or
//      not (rgb x w; w), the prefiltered share of target 0 then 0 (main)
// At RT_SCALE = k > 1 (render.ray_scale) one fragment of the low-resolution targets traces for
// the centre pixel of its k x k block (passes/ssao_upsample.glsl ssao_sample_pixel, as SSAO's
// reduced scale does); passes/rt_upsample.frag brings the filtered result to full resolution.
// The sun's hard shadow needs every pixel: at reduced scale a second draw with RT_SUN_PASS = 1
// (and RT_SCALE 1) traces only the sun's ray, for each pixel of the frame, into target 0.
// Defines: SPECULAR_LOBE, SUN_LIGHT, RT_SUN, ENV_LIGHTS, LIGHT_COUNT, LIGHT_POSITIONAL, RT_SCALE,
// RT_SUN_PASS.
#define RAYTRACED 1
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "passes/lights.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/env_sampling.glsl"
#include "lib/path.glsl"
#include "lib/iridescence.glsl"
#include "passes/raytrace.glsl"
#ifndef RT_SCALE
#define RT_SCALE 1
#endif
#define SSAO_SCALE RT_SCALE
#include "lib/ssao.glsl"
#include "passes/ssao_upsample.glsl"
#ifndef RT_SUN_PASS
#define RT_SUN_PASS 0
#endif

layout(location = 1) out vec4 o_bounce_diffuse;
layout(location = 2) out vec4 o_bounce_specular;

uniform sampler2D u_env_prefiltered;
uniform float u_env_levels;
uniform sampler2D u_env_irradiance;
uniform sampler2D u_env_dfg;
#if SUN_LIGHT
uniform vec3 u_sun_direction;   // unit, towards the sun, the environment's frame
uniform vec3 u_sun_irradiance;  // on a surface facing it
#endif
#if RT_SUN
uniform float u_sun_disc_radius;  // the sun's angular radius (radians)
#endif
#ifndef ENV_LIGHTS
#define ENV_LIGHTS 0
#endif
#ifndef MULTISCATTER
#define MULTISCATTER 0
#endif
#ifndef SUN_LIGHT
#define SUN_LIGHT 0
#endif
#ifndef LIGHT_COUNT
#define LIGHT_COUNT 0
#endif
#if ENV_LIGHTS > 0
uniform vec3 u_env_light_direction[ENV_LIGHTS];   // the environment's other compact lights
uniform vec3 u_env_light_irradiance[ENV_LIGHTS];
uniform float u_env_light_radius[ENV_LIGHTS];     // angular radius, radians
#endif
uniform sampler2D u_env_marginal;     // the environment's distribution (lib/env_sampling.glsl)
uniform sampler2D u_env_conditional;
uniform sampler2D u_env_pdf;
uniform uint u_frame;   // the frame's index in the accumulation (a new sample set each)
uniform uint u_seed;
uniform int u_rt_rays;  // diffuse rays per pixel and frame

#define RT_GLOSSY_F0 0.1  // a hit traces its mirror ray above this F0 (rt_hit_shading)
#define RT_DIFFUSE_ROUGHNESS 0.3  // the chain level the hits' bounce reads the environment at
#ifndef RT_SPECULAR_MC_ROUGHNESS
#define RT_SPECULAR_MC_ROUGHNESS 0.6  // lobes this rough take the Monte Carlo estimate (main)
// (validation: 0.45 lost 3.7 dB on the val spheres' metal of roughness 0.45; 0.6 gains on every
// validation gun, +0.2 to +2.9 dB over the ratio estimator alone)
#endif
#ifndef RT_SPECULAR_MC_BLUR
#define RT_SPECULAR_MC_BLUR 0.5  // its environment read at this fraction of the lobe's roughness
// (validation scenes of bench rays: the same PSNR as 0.25 and 0, the floor's grain under
// lobby.exr 0.0048 against 0.0096 at 0.25; the grazing floor's mean -1.7 % against -0.7 %)
#endif
#ifndef RT_VISIBILITY_ROUGHNESS
#define RT_VISIBILITY_ROUGHNESS 0.1  // the level the diffuse visibility ratio weighs rays by
// (0.1: chosen on the tuned scenes of bench rays, 35.84 dB mean against 35.69 at 0.3)
#endif

vec3 rt_environment(vec3 l, float perceptual_roughness) {
    return ibl_specular_radiance(u_env_prefiltered, env_dir(l), perceptual_roughness, u_env_levels)
           * u_env_intensity;
}

// Candidate k of the light a second hit receives, unshadowed: its irradiance c on the surface
// (normal n at p), the direction l of its visibility ray and that ray's length. k = 0: the
// environment along l_env (a cosine-distributed direction: irradiance pi L); then the sun, the
// environment's other compact lights and the scene's lights, in that order.
#define RT_CANDIDATES (1 + SUN_LIGHT + ENV_LIGHTS + LIGHT_COUNT)
void rt_light_candidate(int k, vec3 p, vec3 n, vec3 l_env, out vec3 c, out vec3 l,
                        out float t_max) {
    c = vec3(0.0);
    l = l_env;
    t_max = 3.0e38;
    if (k == 0) {
        c = PI * rt_environment(l_env, RT_DIFFUSE_ROUGHNESS);
        return;
    }
    k -= 1;
#if SUN_LIGHT
    if (k == 0) {
        l = rotate_y(u_sun_direction, u_env_rotation);
        c = u_sun_irradiance * u_env_intensity * max(dot(n, l), 0.0);
        return;
    }
    k -= 1;
#endif
#if ENV_LIGHTS > 0
    if (k < ENV_LIGHTS) {
        l = rotate_y(u_env_light_direction[k], u_env_rotation);
        vec4 disc = disc_light(n, l, u_env_light_radius[k]);
        c = u_env_light_irradiance[k] * u_env_intensity * max(dot(n, disc.xyz) * disc.w, 0.0);
        return;
    }
    k -= ENV_LIGHTS;
#endif
#if LIGHT_COUNT > 0
    vec4 la = punctual_light(u_light_type[k], u_light_position[k], u_light_direction[k],
                             u_light_cone_range[k], p);
    l = la.xyz;
    c = la.w > 0.0 ? u_light_intensity[k] * (la.w * max(dot(n, la.xyz), 0.0)) : vec3(0.0);
    t_max = u_light_type[k] == LIGHT_TYPE_DIRECTIONAL ? 3.0e38
            : length(u_light_position[k] - p) * (1.0 - 1.0e-4);
#endif
}

// The irradiance the analytic lights give a surface point p (normal n, geometric normal ng, both
// facing the side the light arrives on): every candidate of rt_light_candidate but the
// environment, each behind its own shadow ray.
vec3 rt_direct_irradiance(vec3 p, vec3 n, vec3 ng) {
    vec3 e = vec3(0.0);
    vec3 c, l;
    float t_max;
    for (int k = 1; k < RT_CANDIDATES; ++k) {
        rt_light_candidate(k, p, n, n, c, l, t_max);
        if (max(c.r, max(c.g, c.b)) > 0.0 && !bvh_any_hit(ray_offset(p, ng, l), l, t_max)) {
            e += c;
        }
    }
    return e;
}

// The irradiance a second hit receives, estimated with ONE visibility ray: one candidate of
// rt_light_candidate picked with probability proportional to its unshadowed luminance (u in
// [0, 1)), its light divided by that probability if the ray is free. Unbiased; one ray where
// the environment's ray and a shadow ray per light cost 1 + lights (a 512^2 frame of the tier
// took 1.45 x longer with them all).
vec3 rt_one_light_irradiance(vec3 p, vec3 n, vec3 ng, vec3 l_env, float u) {
    vec3 c, l;
    float t_max, total = 0.0;
    for (int k = 0; k < RT_CANDIDATES; ++k) {
        rt_light_candidate(k, p, n, l_env, c, l, t_max);
        total += luminance(c);
    }
    if (!(total > 0.0)) return vec3(0.0);
    float pick = u * total;
    for (int k = 0; k < RT_CANDIDATES; ++k) {
        rt_light_candidate(k, p, n, l_env, c, l, t_max);
        float w = luminance(c);
        if (pick < w || k == RT_CANDIDATES - 1) {
            if (!(w > 0.0)) return vec3(0.0);
            bool free_ray = !bvh_any_hit(ray_offset(p, ng, l), l, t_max);
            return free_ray ? c * (total / w) : vec3(0.0);
        }
        pick -= w;
    }
    return vec3(0.0);
}

// What a hit surface (normals n, ng facing the ray d) sends back along -d under irradiance e:
// its GGX split sum (lib/shading.glsl ggx_split_sum, the shading pass's own energy split), the
// glossy part the light along the mirror direction - the environment's chain at its roughness
// where one ray escapes, else the surface that ray meets, Lambertian under the irradiance map
// (unshadowed) and the analytic lights (behind their shadow rays), plus its emission. Without
// the glossy part a metal hit
// sent nothing on (the park spheres' floor lost 5.5 % of its light).
vec3 rt_hit_shading(TracedSurface t, vec3 n, vec3 ng, vec3 d, vec3 e) {
    vec3 diffuse = diffuse_color(t.albedo, t.metallic);
    float NoV = dot(n, -d);
    if (!(NoV > 0.0)) return diffuse * INV_PI * e;
    float r = clamp_perceptual_roughness(t.roughness);
    vec3 l = reflect(d, n);
    vec3 glossy = rt_environment(l, r);
    vec4 fresnel = surface_f0_f90(t.albedo, t.metallic, t.specular, t.dielectric);
    // the mirror ray only where the lobe carries light (metals, coloured or strong specular:
    // F0 above RT_GLOSSY_F0); a plain dielectric's 4 % takes the environment unoccluded
    if (max(fresnel.r, max(fresnel.g, fresnel.b)) > RT_GLOSSY_F0 && dot(l, ng) > 0.0) {
        vec3 o = ray_offset(t.p, ng, l);
        RayHit h = bvh_closest_hit(o, l, 3.0e38);
        if (h.triangle >= 0) {
            TracedSurface s = rt_surface(h, o, l);
            bool front = dot(s.ng, l) < 0.0;
            vec3 ns = front ? s.n : -s.n;
            glossy = (front || s.double_sided)
                ? diffuse_color(s.albedo, s.metallic) * INV_PI
                  * (irradiance_lookup(u_env_irradiance, env_dir(ns)) * u_env_intensity
                     + rt_direct_irradiance(s.p, ns, front ? s.ng : -s.ng)) + s.emission
                : vec3(0.0);
        }
    }
#ifdef TRACED_IRIDESCENCE_FIELD
    // the thin film's Fresnel at n.v, as the split-sum shading of the first hit (seen from the
    // coat's IOR under a coat)
#ifdef TRACED_CLEARCOAT_MAPS
    float film_outside = iridescence_outside_ior(t.clearcoat.x);
#else
    float film_outside = 1.0;
#endif
    fresnel.rgb = iridescence_f0(fresnel.rgb, fresnel.a, NoV, t.iridescence, film_outside);
#endif
    return ggx_split_sum(diffuse, fresnel.rgb, fresnel.a, 1.0, e, glossy,
                         ibl_dfg(u_env_dfg, NoV, r), float(MULTISCATTER));
}

// The light a hit surface sends back along the ray (towards -d): Lambertian under the
// environment, the analytic lights (rt_direct_irradiance) and one more bounce, plus its emission.
vec3 rt_hit_radiance(RayHit hit, vec3 o, vec3 d, vec3 u_hit3) {
    vec2 u_hit = u_hit3.xy;
    TracedSurface t = rt_surface(hit, o, d);
    bool front = dot(t.ng, d) < 0.0;
    if (!front && !t.double_sided) return vec3(0.0);
    vec3 n = front ? t.n : -t.n;
    vec3 ng = front ? t.ng : -t.ng;
    // the environment's share through one cosine-distributed ray (irradiance = pi x its
    // radiance): the environment where it escapes, else the light the surface it meets sends
    // back, that surface taken as Lambertian under the environment seen along one more ray and
    // under the analytic lights (a second bounce: the floor beneath a sphere, lit by the sun,
    // lights the sphere's underside, which lights the floor again). The environment is the
    // chain's blurred level, as for the pixel's own rays.
    vec3 lv = tangent_to_world(sample_cosine_hemisphere(u_hit), n);
    vec3 ov = ray_offset(t.p, ng, lv);
    RayHit second = bvh_closest_hit(ov, lv, 3.0e38);
    vec3 e = PI * rt_environment(lv, RT_DIFFUSE_ROUGHNESS);
    if (second.triangle >= 0) {
        TracedSurface t2 = rt_surface(second, ov, lv);
        bool front2 = dot(t2.ng, lv) < 0.0;
        vec3 n2 = front2 ? t2.n : -t2.n;
        vec3 ng2 = front2 ? t2.ng : -t2.ng;
        // the second surface's light - its open sky along one cosine direction (the same
        // direction sample, about its normal) and the analytic lights - behind one visibility
        // ray (rt_one_light_irradiance)
        vec3 l3 = tangent_to_world(sample_cosine_hemisphere(u_hit.yx), n2);
        e = (front2 || t2.double_sided)
            ? diffuse_color(t2.albedo, t2.metallic)
              * rt_one_light_irradiance(t2.p, n2, ng2, l3, u_hit3.z)
              + PI * t2.emission
            : vec3(0.0);
    }
    e += rt_direct_irradiance(t.p, n, ng);
    return rt_hit_shading(t, n, ng, d, e) + t.emission;
}

void main() {
    ivec2 pixel = ssao_sample_pixel(ivec2(gl_FragCoord.xy));  // itself at RT_SCALE 1
    vec2 frag = vec2(pixel) + 0.5;
    GBuffer g = gbuffer_load(pixel);
    if (g.alpha <= 0.0 || !(g.depth > 0.0)) {  // nothing to shade: ratios of 1, no bounce
        o_radiance = vec4(1.0);
        o_bounce_diffuse = vec4(0.0, 0.0, 0.0, 1.0);
        o_bounce_specular = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    vec3 v = -view_ray_ws(frag);
    vec3 n = shading_normal(g.normal, v);
    vec3 p = light_surface_position(frag, g.depth);
    uvec2 px = uvec2(pixel);
#if RT_SUN
    // the sun's visibility: one ray towards a uniform point of its disc (soft edges as the
    // frames accumulate; this channel is not filtered: rt_filter.frag keeps it)
    vec3 l_sun = rotate_y(u_sun_direction, u_env_rotation);
    vec3 ld = tangent_to_world(sample_uniform_cone(mc_sample_2d(px.x, px.y, u_frame, u_seed, 4u),
                                                   cos(u_sun_disc_radius)), l_sun);
    float sun_seen = bvh_any_hit(ray_offset(p, n, ld), ld, 3.0e38) ? 0.0 : 1.0;
#if RT_SUN_PASS
    o_radiance = vec4(sun_seen);
    o_bounce_diffuse = vec4(0.0, 0.0, 0.0, 1.0);
    o_bounce_specular = vec4(0.0, 0.0, 0.0, 1.0);
    return;
#endif
#endif
    float seen = 0.0;
    float all_light = 0.0;
    vec3 bounce = vec3(0.0);
    int rays = max(u_rt_rays, 1);
    for (int k = 0; k < rays; ++k) {
        uint index = u_frame * uint(rays) + uint(k);
        vec3 l = tangent_to_world(sample_cosine_hemisphere(
            mc_sample_2d(px.x, px.y, index, u_seed, 0u)), n);
        // L cos / (rays pdf_cos + pdf_env): the balance heuristic's share of this sample
        float light = luminance(rt_environment(l, RT_VISIBILITY_ROUGHNESS)) * max(dot(l, n), 0.0)
                      / (float(rays) * max(dot(l, n), 0.0) * INV_PI
                         + env_pdf(u_env_pdf, env_dir(l)));
        vec3 o = ray_offset(p, n, l);
        RayHit hit = bvh_closest_hit(o, l, 3.0e38);
        all_light += light;
        if (hit.triangle < 0) seen += rt_escapes(o, l, 3.0e38) ? light : 0.0;
        else bounce += rt_hit_radiance(hit, o, l, vec3(mc_sample_2d(px.x, px.y, index, u_seed, 2u),
                                                  mc_sample_2d(px.x, px.y, index, u_seed, 6u).x));
    }
    // one direction from the environment's distribution, for the visibility ratio only
    vec4 e = sample_env(u_env_marginal, u_env_conditional, u_env_pdf,
                        mc_sample_2d(px.x, px.y, u_frame, u_seed, 5u));
    vec3 le = rotate_y(e.xyz, u_env_rotation);
    float ce = dot(le, n);
    if (e.w > 0.0 && ce > 0.0) {
        float light = luminance(rt_environment(le, RT_VISIBILITY_ROUGHNESS)) * ce
                      / (float(rays) * ce * INV_PI + e.w);
        all_light += light;
        if (!bvh_any_hit(ray_offset(p, n, le), le, 3.0e38)) seen += light;
    }
    float inv = 1.0 / float(rays);
    vec4 ratios = vec4(seen, all_light, 1.0, 1.0);
    o_bounce_diffuse = vec4(bounce * inv, 1.0);
#if RT_SUN
    o_bounce_diffuse.a = sun_seen;
#endif
    o_bounce_specular = vec4(0.0, 0.0, 0.0, 1.0);
#if SPECULAR_LOBE
    float r = clamp_perceptual_roughness(g.roughness);
    vec3 t = tangent_to_world(vec3(1.0, 0.0, 0.0), n);
    vec3 b = tangent_to_world(vec3(0.0, 1.0, 0.0), n);
    vec3 v_t = vec3(dot(v, t), dot(v, b), max(dot(v, n), 1e-4));
    vec3 h = tangent_to_world(sample_ggx_vndf(mc_sample_2d(px.x, px.y, u_frame, u_seed, 1u), v_t,
                                              r * r), n);
    vec3 ls = reflect(-v, h);
    vec3 u_bounce = vec3(mc_sample_2d(px.x, px.y, u_frame, u_seed, 3u),
                         mc_sample_2d(px.x, px.y, u_frame, u_seed, 6u).y);
    if (r >= RT_SPECULAR_MC_ROUGHNESS) {
        // a wide lobe: its radiance by Monte Carlo, the VNDF ray's light weighted by
        // G2(v, l) / G1(v) (f n.l / pdf but the Fresnel term, which the DFG scale carries) and
        // self-normalised by the accumulated weights (alpha; rt_specular_radiance divides).
        // A ray below the surface weighs 0: the lobe is clipped at the horizon, where the
        // round prefiltered lookup of a grazing lobe also reads the sky beneath it (a rough
        // floor under park.exr: the split sum's specular term is 22 % short at grazing)
        float NoL = dot(ls, n);
        float NoV = max(dot(v, n), 1e-4);
        float a = r * r;
        vec4 f = surface_f0_f90(g.albedo, g.metallic, g.specular, g.dielectric);
        float w = NoL > 0.0 ? luminance(f_schlick(f.rgb, f.a, saturate(dot(v, h))))
                              * 4.0 * NoL * NoV * v_smith_ggx_correlated(NoV, NoL, a)
                              / g1_smith_ggx(NoV, a) : 0.0;
        ratios.zw = vec2(0.0, 1.0);  // no prefiltered share
        o_bounce_specular = vec4(0.0);
        if (w > 0.0) {
            vec3 o = ray_offset(p, n, ls);
            RayHit hit = bvh_closest_hit(o, ls, 3.0e38);
            vec3 c = hit.triangle < 0 ? rt_environment(ls, r * RT_SPECULAR_MC_BLUR)
                                      : rt_hit_radiance(hit, o, ls, u_bounce);
            o_bounce_specular = vec4(w * c, w);
        }
    } else {
        // the ratio estimator: the prefiltered lookup times the share of the lobe's light
        // the ray sees, plus the light its hit brings back
        if (!(dot(ls, n) > 0.0)) ls = reflect(-v, n);  // below the surface: the mirror direction
        float light = luminance(rt_environment(ls, r));
        vec3 o = ray_offset(p, n, ls);
        RayHit hit = bvh_closest_hit(o, ls, 3.0e38);
        ratios.zw = vec2(hit.triangle < 0 && rt_escapes(o, ls, 3.0e38) ? light : 0.0, light);
        if (hit.triangle >= 0) o_bounce_specular = vec4(rt_hit_radiance(hit, o, ls, u_bounce), 1.0);
    }
#endif
    o_radiance = ratios;
}

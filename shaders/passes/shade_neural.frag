// shade_neural.frag - the distilled neural shader (learned/neural/student.py): one MLP evaluation
// per pixel on the material, n.v and the pre-integrated lighting (the exact irradiance map, GGX-prefiltered
// radiance, and the split-sum DFG LUT for students with NEURAL_STUDENT_DFG) every classical model
// reads. The network is generated code from an exported weights file (viewer/neural/ ->
// "generated/neural_student.glsl": weights baked as constants, or read from the uniform/storage
// block or texture it declares, per [render] neural_storage; it defines NEURAL_STUDENT_DFG and
// NEURAL_STUDENT_PBR, the output form: 1 = pbr3, three achromatic factors of the split-sum form,
// colour from the material; 0 = free6, six per-channel factors; lib/neural.glsl; and
// NEURAL_STUDENT_VIS: the student reads the screen-space visibility of the environment's light,
// the g channel of u_ssao, which the renderer then computes: passes/ssao.frag, SSAO_ENV_VIS;
// NEURAL_STUDENT_ENV: it reads u_env_below, how bright the environment is from below).
// NEURAL_STUDENT_INDIRECT: the student learned a factor on the screen-space indirect light; the
// pass writes it (lib/neural.glsl neural_indirect_factor, 1 on the background) to the second
// target o_indirect_factor, which the renderer allocates for it and passes/ssao.frag
// (SSAO_INDIRECT_FACTOR) multiplies into its one-bounce light. NEURAL_STUDENT_MULTISCATTER: the
// split3 base is ggx_split_sum with its multiple-scattering compensation (architecture
// "multiscatter": true), so an untrained student renders the classical model's default.
// Defines: USE_AO, USE_SSAO (the occlusion input), BACKGROUND_ENVIRONMENT (0/1), SUN_LIGHT (0/1,
// 0 when not given: a split3 student with NEURAL_STUDENT_SUN under an environment with a sun; the
// IBL bound then leaves the sun out of the prefiltered chain and the irradiance map,
// u_env_prefiltered_full keeps it, and the sun is shaded as shade_ggx_split_sum.frag shades it,
// with the student's corrections: lib/neural.glsl neural_student_sun_split), ENV_LIGHTS (the
// environment's other compact lights: the student's input takes one sun, so they go through its
// classical base, passes/env_lights.glsl, without learned factors, diffuse times ao as the
// base scales it), LIGHT_COUNT, LIGHT_POSITIONAL (the
// scene's punctual lights through the student's classical base: passes/lights.glsl, main()).
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "passes/lights.glsl"
#include "passes/rt_light.glsl"
#include "passes/env_lights.glsl"
#include "generated/neural_student.glsl"

#ifndef SUN_LIGHT
#define SUN_LIGHT 0
#endif
#ifndef NEURAL_STUDENT_MULTISCATTER
#define NEURAL_STUDENT_MULTISCATTER 0
#endif
#if SUN_LIGHT && !(NEURAL_STUDENT_SPLIT && NEURAL_STUDENT_SUN)
#error "SUN_LIGHT needs a split3 student trained with the sun (architecture \"sun\": true)"
#endif

uniform sampler2D u_env_prefiltered;
uniform float u_env_levels;
uniform sampler2D u_env_irradiance;  // exact irradiance map (lib/ibl.glsl irradiance_lookup)
// the environment's irradiance from below over above (viewer.environment.irradiance.env_below,
// set by IBL.bind): an input of students with NEURAL_STUDENT_ENV, unused otherwise
uniform float u_env_below;
#if NEURAL_STUDENT_DFG || NEURAL_STUDENT_SPLIT
uniform sampler2D u_env_dfg;
#endif
#if NEURAL_STUDENT_SPLIT
uniform sampler2D u_env_dominant;
#endif
#if SUN_LIGHT
uniform sampler2D u_env_prefiltered_full;  // the prefiltered chain with the sun
uniform vec3 u_sun_direction;   // unit, towards the sun, the environment's frame
uniform vec3 u_sun_irradiance;  // on a surface facing it (times u_env_intensity)
uniform float u_sun_radius;     // the widest extracted light's angular radius (radians): w
uniform float u_sun_disc_radius;  // the sun's own angular radius (radians): its horizon
#endif
#if NEURAL_STUDENT_INDIRECT
layout(location = 1) out vec4 o_indirect_factor;  // r: the factor on L_ind (all four channels)
#endif

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec3 d = view_ray_ws(gl_FragCoord.xy);
    vec3 background = background_radiance(d);
    if (g.alpha <= 0.0) {
#if NEURAL_STUDENT_INDIRECT
        o_indirect_factor = vec4(1.0);
#endif
        write_radiance(vec3(0.0), background, 0.0);
        return;
    }
    vec3 v = -d;
    vec3 n = shading_normal(g.normal, v);
    float NoV = saturate(dot(n, v));
    float r = clamp_perceptual_roughness(g.roughness);
    // RT_LIGHT: the real-time tier's visible share and bounce (passes/rt_light.glsl), as the
    // classical models take them; the student's visibility input then reads 1 (no SSAO)
    vec3 irradiance = rt_diffuse_irradiance(
        pixel, irradiance_lookup(u_env_irradiance, env_dir(n)) * u_env_intensity);
#if NEURAL_STUDENT_SPLIT  // the split-sum model's lookup direction (shade_ggx_split_sum.frag)
    vec3 reflected = specular_dominant_direction(n, reflect(-v, n),
                                                 ibl_dominant_factor(u_env_dominant, NoV, r));
#else
    vec3 reflected = reflect(-v, n);
#endif
#if SUN_LIGHT
    // the sun's specular light: analytic for the share w, looked up (with the sun) for the rest,
    // as shade_ggx_split_sum.frag
    float w_sun = sun_specular_weight(r * r, u_sun_radius);
    vec3 prefiltered = ibl_specular_radiance_sun(u_env_prefiltered, u_env_prefiltered_full,
                                                 env_dir(reflected), r, u_env_levels, w_sun)
                       * u_env_intensity;
#else
    vec3 prefiltered = ibl_specular_radiance(u_env_prefiltered, env_dir(reflected), r,
                                             u_env_levels) * u_env_intensity;
#endif
    prefiltered = rt_specular_radiance(pixel, prefiltered);  // RT_LIGHT: seen share, bounce
#if NEURAL_STUDENT_DFG || NEURAL_STUDENT_SPLIT
    vec2 dfg = ibl_dfg(u_env_dfg, NoV, r);
#else
    vec2 dfg = vec2(0.0);
#endif
    float ao = ambient_occlusion(pixel, g);
#if SPECULAR_OCCLUSION  // as ggx_split_sum: the occluded share of the lobe, before the network
    prefiltered *= specular_occlusion(NoV, ao, r * r);
#endif
#if NEURAL_STUDENT_VIS && USE_SSAO
    float vis = ssao_channel(pixel, 1);  // S(x), or the shadow estimator's V (SSAO_SHADOW_NET)
#else
    float vis = 1.0;
#endif
    vec3 k_0;
    vec3 k_1;
    neural_student_weights(g.albedo, g.roughness, g.metallic, g.specular, ao, NoV, dfg, vis,
                           u_env_below, k_0, k_1);
#if NEURAL_STUDENT_SPLIT
    vec3 f0 = compute_f0(g.albedo, g.metallic, g.specular);
#if NEURAL_STUDENT_MULTISCATTER  // its base: ggx_split_sum with the energy compensation
    vec3 spec_scale = ibl_energy_compensation(dfg, f0);
#else
    vec3 spec_scale = vec3(1.0);
#endif
    vec3 c = neural_student_radiance_split(k_0, diffuse_color(g.albedo, g.metallic), f0,
                                           f90_from_f0(f0), dfg, irradiance, prefiltered,
                                           spec_scale);
#if SUN_LIGHT
    vec3 l_sun = rotate_y(u_sun_direction, u_env_rotation);
    vec4 disc = disc_light(n, l_sun, u_sun_disc_radius);
    c += neural_student_sun_split(k_0, diffuse_color(g.albedo, g.metallic), f0, f90_from_f0(f0),
                                  dfg, r * r, n, v, disc.xyz,
                                  u_sun_irradiance * u_env_intensity * disc.w
                                  * sun_shadow(g, n, l_sun), w_sun, spec_scale);
    c += env_lights_ggx(diffuse_color(g.albedo, g.metallic) * ao, f0, f90_from_f0(f0), r * r, dfg,
                        float(NEURAL_STUDENT_MULTISCATTER), n, v, w_sun,
                        light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#elif NEURAL_STUDENT_PBR
    vec3 f0 = compute_f0(g.albedo, g.metallic, g.specular);
    vec3 c = neural_student_radiance_pbr(k_0, diffuse_color(g.albedo, g.metallic), f0,
                                         f90_from_f0(f0), irradiance, prefiltered);
#else
    vec3 c = neural_student_radiance(k_0, k_1, g.albedo, irradiance, prefiltered);
#endif
#if LIGHT_COUNT > 0
    // the scene's punctual lights through the student's classical base, its BRDF without the
    // learned factors (they were trained under environment light): GGX + Lambert with the base's
    // energy split (the DFG terms of a split or dfg student, none (e_spec = 0) otherwise) and its
    // multiple-scattering compensation (NEURAL_STUDENT_MULTISCATTER)
#if NEURAL_STUDENT_SPLIT && NEURAL_STUDENT_MULTISCATTER
    float ms_l = 1.0;
#else
    float ms_l = 0.0;
#endif
    vec3 f0_l = compute_f0(g.albedo, g.metallic, g.specular);
    c += lights_ggx(diffuse_color(g.albedo, g.metallic), f0_l, f90_from_f0(f0_l), r * r, dfg, ms_l,
                    n, v,
                    light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#if NEURAL_STUDENT_INDIRECT
    o_indirect_factor = vec4(neural_indirect_factor(k_1.x));
#endif
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

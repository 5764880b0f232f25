// shade_ggx_split_sum.frag - Cook-Torrance GGX with split-sum image-based lighting.
// Defines: MULTISCATTER (0/1), USE_AO (0/1), USE_SSAO (0/1), BACKGROUND_ENVIRONMENT (0/1),
// SPECULAR_LOBE (0/1: 0 compiles the specular lookups out for scenes without any f0 > 0),
// LIGHT_COUNT, LIGHT_POSITIONAL (the scene's punctual lights, same BRDF: passes/lights.glsl),
// SUN_LIGHT (0/1: the environment's sun as an analytic light, viewer/environment/sun.py; the IBL bound then
// leaves it out of the prefiltered chain and the irradiance map, and u_env_prefiltered_full keeps
// it), ENV_LIGHTS (its other compact lights, passes/env_lights.glsl; with SUN_LIGHT only),
// RT_LIGHT (the real-time tier's ray-traced visibility and bounce: passes/rt_light.glsl),
// FORWARD_TRANSMISSION (deferred.glsl: a KHR_materials_transmission surface in the forward pass).
// GBUFFER_HAS_ANISOTROPY (KHR_materials_anisotropy, passes/anisotropy_lights.glsl): the
// prefiltered light of anisotropic_prefiltered (the spec's bent normal and lookups along t),
// scaled by the stretched lobe's albedo over the isotropic DFG's (anisotropy_albedo_ratio); the
// analytic lights' specular anisotropic.
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "lib/layers.glsl"
#include "lib/iridescence.glsl"
#include "passes/lights.glsl"
#include "passes/rt_light.glsl"
#include "passes/env_lights.glsl"
#include "passes/anisotropy_lights.glsl"

uniform sampler2D u_env_prefiltered;
uniform sampler2D u_env_dfg;
uniform sampler2D u_env_dominant;
uniform float u_env_levels;
uniform sampler2D u_env_irradiance;  // exact irradiance map (lib/ibl.glsl irradiance_lookup)
#if SUN_LIGHT
uniform sampler2D u_env_prefiltered_full;  // the prefiltered chain with the sun
uniform vec3 u_sun_direction;   // unit, towards the sun, the environment's frame
uniform vec3 u_sun_irradiance;  // on a surface facing it (times u_env_intensity)
uniform float u_sun_radius;     // the widest extracted light's angular radius (radians): w
uniform float u_sun_disc_radius;  // the sun's own angular radius (radians): its horizon
#endif

#if GBUFFER_HAS_CLEARCOAT
// KHR_materials_clearcoat (lib/layers.glsl): the base's radiance c keeps 1 - w of itself, w the
// coat's weight c F_c(n_c.v); the coat adds its split-sum environment term, looked up in the
// chain of the whole environment (with SUN_LIGHT its sun and compact lights too: the coat's
// reflection of them is the prefiltered one, unshadowed), and its punctual lights at p.
vec3 clearcoat_radiance(vec3 c, GBuffer g, vec3 v, vec3 p) {
    if (!(g.clearcoat.x > 0.0)) return c;
    vec3 n_c = shading_normal(oct_decode(g.clearcoat.zw), v);
    float NoV = saturate(dot(n_c, v));
    float r = clamp_perceptual_roughness(g.clearcoat.y);
    float w = clearcoat_weight(g.clearcoat.x, NoV);
#if SUN_LIGHT
    vec3 pre = ibl_specular_radiance(u_env_prefiltered_full, env_dir(reflect(-v, n_c)), r,
                                     u_env_levels);
#else
    vec3 pre = ibl_specular_radiance(u_env_prefiltered, env_dir(reflect(-v, n_c)), r,
                                     u_env_levels);
#endif
    vec3 coat = clearcoat_split_sum(w, ibl_dfg(u_env_dfg, NoV, r), pre * u_env_intensity);
#if LIGHT_COUNT > 0
    coat += lights_clearcoat(w, r * r, n_c, v, p);
#endif
    return c * (1.0 - w) + coat;
}
#endif

#if GBUFFER_HAS_ANISOTROPY
// The prefiltered radiance along d (world space), as the isotropic lookup below reads it.
vec3 prefiltered_along(vec3 d, float r, float w_sun) {
#if SUN_LIGHT
    return ibl_specular_radiance_sun(u_env_prefiltered, u_env_prefiltered_full, env_dir(d), r,
                                     u_env_levels, w_sun);
#else
    return ibl_specular_radiance(u_env_prefiltered, env_dir(d), r, u_env_levels);
#endif
}

// KHR_materials_anisotropy's environment light: the spec's two suggestions together - the
// reflection about its bent normal (lib/anisotropy.glsl anisotropy_bent_normal, three.js's and
// Filament's single lookup) and further lookups on both sides along t spaced by the lobe's extra
// spread sqrt(at^2 - ab^2): four microfacet slopes at the quartiles +-0.26, +-1.13 of GGX's
// slope marginal (CDF (1 + x / sqrt(1 + x^2)) / 2), each reflection above the horizon looked
// up at the narrow axis's roughness r, averaged. On the test grid (test_gltf_anisotropy.py)
// the bent normal alone is 32 % too bright on the vertically brushed sphere (median pixel 80 %).
vec3 anisotropic_prefiltered(vec3 n, vec3 t, vec3 v, vec2 alphas, float strength, float r,
                             float dominant, float w_sun) {
    vec3 n_b = anisotropy_bent_normal(n, cross(n, t), v, strength, r);
    float spread = sqrt(max(alphas.x * alphas.x - alphas.y * alphas.y, 0.0));
    const float slopes[4] = float[](-1.1339, -0.2582, 0.2582, 1.1339);
    vec3 sum = vec3(0.0);
    float count = 0.0;
    for (int k = 0; k < 4; ++k) {
        vec3 l = reflect(-v, normalize(n_b + spread * slopes[k] * t));
        if (dot(n, l) > 0.0) {
            sum += prefiltered_along(specular_dominant_direction(n, l, dominant), r, w_sun);
            count += 1.0;
        }
    }
    if (count > 0.0) return sum / count;
    return prefiltered_along(specular_dominant_direction(n_b, reflect(-v, n_b), dominant), r,
                             w_sun);
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec3 d = view_ray_ws(gl_FragCoord.xy);
    vec3 background = background_radiance(d);
    if (g.alpha <= 0.0) {
        write_radiance(vec3(0.0), background, 0.0);
        return;
    }
    vec3 v = -d;
    vec3 n = shading_normal(g.normal, v);
    vec3 irradiance = rt_diffuse_irradiance(
        pixel, irradiance_lookup(u_env_irradiance, env_dir(n)) * u_env_intensity);
    float ao = ambient_occlusion(pixel, g);
    // the environment's shadows (ENV_SHADOWS) darken the light the irradiance map holds, not the
    // analytic lights (which have their own maps)
    float ao_env = ao * env_shadow(g, n);
#if SPECULAR_LOBE
    float NoV = saturate(dot(n, v));
    float r = clamp_perceptual_roughness(g.roughness);
    vec3 reflected = specular_dominant_direction(n, reflect(-v, n),
                                                 ibl_dominant_factor(u_env_dominant, NoV, r));
#if SUN_LIGHT
    // the sun's specular light: analytic for the share w, looked up (with the sun) for the rest
    float w_sun = sun_specular_weight(r * r, u_sun_radius);
#if GBUFFER_HAS_ANISOTROPY
    // a stretched lobe: its analytic share by the mean width sqrt(alpha_t alpha_b) (under the
    // studio's lamps the mean |split sum - path| over a brushed sphere drops from 58 to 42 %
    // of the light, from 45 to 26 % brushed across; the prefiltered taps otherwise mirror the
    // lamp sharply)
    {
        vec4 ak = anisotropy_at(GBUFFER_ANISOTROPY(g), g.normal, n);
        vec2 al = anisotropy_alphas(r * r, ak.w);
        if (ak.w > 0.0) w_sun = sun_specular_weight(sqrt(al.x * al.y), u_sun_radius);
    }
#endif
    vec3 prefiltered = ibl_specular_radiance_sun(u_env_prefiltered, u_env_prefiltered_full,
                                                 env_dir(reflected), r, u_env_levels, w_sun)
                       * u_env_intensity;
#else
    vec3 prefiltered = ibl_specular_radiance(u_env_prefiltered, env_dir(reflected), r, u_env_levels)
                       * u_env_intensity;
#endif
#if GBUFFER_HAS_ANISOTROPY
    // KHR_materials_anisotropy: the stretched lobe's prefiltered light (its albedo below)
    vec4 aniso = anisotropy_at(GBUFFER_ANISOTROPY(g), g.normal, n);
    vec2 alphas = anisotropy_alphas(r * r, aniso.w);
    if (aniso.w > 0.0) {
#if SUN_LIGHT
        float w_a = w_sun;
#else
        float w_a = 1.0;
#endif
        prefiltered = anisotropic_prefiltered(n, aniso.xyz, v, alphas, aniso.w, r,
                                              ibl_dominant_factor(u_env_dominant, NoV, r), w_a)
                      * u_env_intensity;
    }
#endif
    prefiltered = rt_specular_radiance(pixel, prefiltered);  // RT_LIGHT: seen share, bounce
#if SPECULAR_OCCLUSION
    prefiltered *= specular_occlusion(NoV, ao, r * r);  // the occluded share of the lobe
#endif
    vec2 dfg = ibl_dfg(u_env_dfg, NoV, r);
    vec3 diffuse = diffuse_color(g.albedo, g.metallic);
    vec4 fresnel = surface_f0_f90(g.albedo, g.metallic, g.specular, g.dielectric);
    vec3 f0 = fresnel.rgb;
    float f90 = fresnel.a;
#if GBUFFER_HAS_IRIDESCENCE
    // KHR_materials_iridescence (lib/iridescence.glsl): the thin film's Fresnel at n.v in place
    // of the Schlick F0 term (three.js), for the environment's light and the lights' alike; under
    // a coat the film is seen from the coat's IOR (the spec: the coat is evaluated first)
#if GBUFFER_HAS_CLEARCOAT
    float film_outside = iridescence_outside_ior(g.clearcoat.x);
#else
    float film_outside = 1.0;
#endif
    f0 = iridescence_f0(f0, f90, NoV, g.iridescence, film_outside);
#endif
#if FORWARD_TRANSMISSION
    // KHR_materials_transmission (the forward pass, passes/forward_surface.glsl): the base's
    // share T receives the opaque frame refracted through the surface in place of its
    // irradiance, weighted by the same 1 - E_spec; the lights below light the rest, 1 - T
    vec3 c = ggx_split_sum(diffuse, f0, f90, 1.0,
                           transmission_irradiance(irradiance * ao_env, g.transmission,
                                                   refracted_radiance(g, n, v)),
                           prefiltered, dfg, float(MULTISCATTER));
    diffuse *= 1.0 - saturate(g.transmission);
#else
    vec3 c = ggx_split_sum(diffuse, f0, f90, ao_env, irradiance, prefiltered, dfg,
                           float(MULTISCATTER));
#endif
#if GBUFFER_HAS_ANISOTROPY
    if (aniso.w > 0.0) {  // the environment's specular at the stretched lobe's albedo
        vec3 b_a = cross(n, aniso.xyz);
        float ratio = anisotropy_albedo_ratio(vec3(dot(v, aniso.xyz), dot(v, b_a), NoV), alphas);
        vec3 e_spec = ibl_specular_dfg(dfg, f0, f90)
                      * (MULTISCATTER != 0 ? ibl_energy_compensation(dfg, f0) : vec3(1.0));
        c += e_spec * prefiltered * (ratio - 1.0);
    }
#endif
#if GBUFFER_HAS_SHEEN
    // KHR_materials_sheen (lib/layers.glsl): under the environment the base keeps the spec's
    // cheaper 1 - max3(C) E(n.v) and the sheen adds C E(n.v) irradiance(n) / pi (three.js's
    // sheen IBL: the Charlie lobe is wide, its light comes from the whole hemisphere; the
    // irradiance carries the rays' visibility, ao_env the occlusion); the punctual lights, the sun and the other
    // extracted lights (not in the irradiance map) scale the base light by light with the
    // spec's exact min form and add the sheen's reflection of them (sheen_light)
    vec3 sheen = g.sheen.rgb;
    float r_sheen = clamp(g.sheen.a, SHEEN_MIN_ROUGHNESS, 1.0);
    float e_sheen = sheen_albedo(NoV, r_sheen);
    c = c * sheen_scaling(sheen, e_sheen, e_sheen)
        + sheen_split_sum(sheen, e_sheen, irradiance * (ao_env * INV_PI));
#if LIGHT_COUNT > 0
    c += lights_ggx_sheen(diffuse, f0, f90, r * r, dfg, float(MULTISCATTER), n, v,
                          light_surface_position(gl_FragCoord.xy, g.depth), sheen, r_sheen,
                          e_sheen);
#endif
#if SUN_LIGHT
    vec3 l_sun = rotate_y(u_sun_direction, u_env_rotation);
    vec4 disc = disc_light(n, l_sun, u_sun_disc_radius);
    vec3 e_sun = u_sun_irradiance * u_env_intensity * disc.w * sun_shadow(g, n, l_sun);
    c += ggx_environment_sun(diffuse * ao, f0, f90, r * r, dfg, float(MULTISCATTER), n, v,
                             disc.xyz, e_sun, w_sun)
         * sheen_scaling(sheen, e_sheen, sheen_albedo(dot(n, disc.xyz), r_sheen))
         + sheen_light(sheen, r_sheen, n, v, disc.xyz) * e_sun;
    c += env_lights_ggx_sheen(diffuse * ao, f0, f90, r * r, dfg, float(MULTISCATTER), n, v,
                              w_sun, light_surface_position(gl_FragCoord.xy, g.depth), sheen,
                              r_sheen, e_sheen);
#endif
#else
#if LIGHT_COUNT > 0
    c += lights_ggx(diffuse, f0, f90, r * r, dfg, float(MULTISCATTER), n, v,
                    light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#if SUN_LIGHT
    // ao scales its diffuse part as it scales the rest of the environment's (SH) diffuse light
    vec3 l_sun = rotate_y(u_sun_direction, u_env_rotation);
    vec4 disc = disc_light(n, l_sun, u_sun_disc_radius);
    c += ggx_environment_sun(diffuse * ao, f0, f90, r * r, dfg, float(MULTISCATTER), n, v,
                             disc.xyz,
                             u_sun_irradiance * u_env_intensity * disc.w
                             * sun_shadow(g, n, l_sun), w_sun);
    c += env_lights_ggx(diffuse * ao, f0, f90, r * r, dfg, float(MULTISCATTER), n, v, w_sun,
                        light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#endif  // GBUFFER_HAS_SHEEN
#if GBUFFER_HAS_ANISOTROPY
    if (aniso.w > 0.0) {  // the analytic lights' specular: the anisotropic lobe's
        vec3 spec_scale = MULTISCATTER != 0 ? ibl_energy_compensation(dfg, f0) : vec3(1.0);
        vec3 p_a = light_surface_position(gl_FragCoord.xy, g.depth);
        c += lights_anisotropy(f0, f90, spec_scale, n, aniso.xyz, v, alphas, p_a);
#if SUN_LIGHT
        vec3 l_sun_a = rotate_y(u_sun_direction, u_env_rotation);
        vec4 disc_a = disc_light(n, l_sun_a, u_sun_disc_radius);
        c += anisotropy_specular_delta(f0, f90, n, aniso.xyz, v, disc_a.xyz, alphas) * spec_scale
             * (u_sun_irradiance * (u_env_intensity * disc_a.w * w_sun
                                    * sun_shadow(g, n, l_sun_a)));
        c += env_lights_anisotropy(f0, f90, spec_scale, n, aniso.xyz, v, alphas, w_sun, p_a);
#endif
    }
#endif
#else  // no specular lobe in the scene (a sheen is one: analyse() counts it)
    // f0 = 0 everywhere: ggx_split_sum reduces exactly to its diffuse term (e_spec = 0), and so
    // does the light's BRDF (F = 0; any alpha)
    vec3 diffuse = diffuse_color(g.albedo, g.metallic);
    vec3 c = ggx_split_sum(diffuse, vec3(0.0), 0.0, ao_env, irradiance, vec3(0.0), vec2(0.0, 1.0),
                           0.0);
#if LIGHT_COUNT > 0
    c += lights_ggx(diffuse, vec3(0.0), 0.0, 1.0, vec2(0.0, 1.0), 0.0, n, v,
                    light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#if SUN_LIGHT
    vec3 l_sun = rotate_y(u_sun_direction, u_env_rotation);
    vec4 disc = disc_light(n, l_sun, u_sun_disc_radius);
    c += ggx_directional_light(diffuse * ao, vec3(0.0), 0.0, 1.0, vec2(0.0, 1.0), 0.0, n, v,
                               disc.xyz,
                               u_sun_irradiance * u_env_intensity * disc.w
                               * sun_shadow(g, n, l_sun));
    c += env_lights_ggx(diffuse * ao, vec3(0.0), 0.0, 1.0, vec2(0.0, 1.0), 0.0, n, v, 1.0,
                        light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#endif
#if GBUFFER_HAS_CLEARCOAT
    c = clearcoat_radiance(c, g, v, light_surface_position(gl_FragCoord.xy, g.depth));
#endif
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

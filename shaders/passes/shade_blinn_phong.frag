// shade_blinn_phong.frag - the thesis's classical baseline under environment light.
// Defines: USE_AO (0/1), USE_SSAO (0/1), BACKGROUND_ENVIRONMENT (0/1), SPECULAR_LOBE (0/1),
// LIGHT_COUNT, LIGHT_POSITIONAL (the scene's punctual lights, passes/lights.glsl),
// FORWARD_TRANSMISSION (deferred.glsl: a KHR_materials_transmission surface in the forward pass).
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "passes/lights.glsl"
#include "passes/rt_light.glsl"

uniform sampler2D u_env_prefiltered;
uniform float u_env_levels;
uniform sampler2D u_env_irradiance;  // exact irradiance map (lib/ibl.glsl irradiance_lookup)

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
    float r = clamp_perceptual_roughness(g.roughness);
    vec3 prefiltered = ibl_specular_radiance(u_env_prefiltered, env_dir(reflect(-v, n)), r,
                                             u_env_levels) * u_env_intensity;
    prefiltered = rt_specular_radiance(pixel, prefiltered);  // RT_LIGHT: seen share, bounce
    vec3 diffuse = diffuse_color(g.albedo, g.metallic);
    vec3 f0 = surface_f0_f90(g.albedo, g.metallic, g.specular, g.dielectric).rgb;
#if FORWARD_TRANSMISSION
    // KHR_materials_transmission (the forward pass, passes/forward_surface.glsl): the base's
    // share T receives the refracted opaque frame in place of its irradiance, weighted by the
    // same 1 - f0; the lights light the rest, 1 - T
    vec3 c = blinn_phong(diffuse, f0, 1.0,
                         transmission_irradiance(irradiance * ao_env, g.transmission,
                                                 refracted_radiance(g, n, v)),
                         prefiltered);
    diffuse *= 1.0 - saturate(g.transmission);
#else
    vec3 c = blinn_phong(diffuse, f0, ao_env, irradiance, prefiltered);
#endif
#if LIGHT_COUNT > 0
    c += lights_blinn_phong(diffuse, f0, r * r, n, v,
                            light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#else
    vec3 diffuse = diffuse_color(g.albedo, g.metallic);
    vec3 c = blinn_phong(diffuse, vec3(0.0), ao_env, irradiance, vec3(0.0));
#if LIGHT_COUNT > 0  // f0 = 0: the lobe's weight is exactly 0 (any alpha)
    c += lights_blinn_phong(diffuse, vec3(0.0), 1.0, n, v,
                            light_surface_position(gl_FragCoord.xy, g.depth));
#endif
#endif
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

// anisotropy_lights.glsl (pass chunk) - KHR_materials_anisotropy in the rasterised models'
// lighting (ggx_split_sum, ggx_mc's analytic lights): the pixel's anisotropic frame from the
// G-buffer's channel, the bent normal of the prefiltered lookup, and the light by light
// correction (lib/anisotropy.glsl anisotropy_specular_delta) that turns the isotropic specular
// of lights_ggx / env_lights_ggx / the sun into the anisotropic lobe's. Compiled only with
// GBUFFER_HAS_ANISOTROPY; included after passes/lights.glsl and passes/env_lights.glsl.
// Not corrected: the combination with a KHR_materials_sheen sheen (the correction is not scaled
// by the sheen's albedo scaling; no test asset has both). The library is included whatever
// the layout (the include resolver includes a file once, whatever #if surrounds it).
#include "lib/anisotropy.glsl"
#if GBUFFER_HAS_ANISOTROPY

// (t, strength) at a pixel: the channel's value k decoded with the stored normal g_n, t then
// put into the plane of the shading normal n (shading_normal may bend g_n towards the viewer).
vec4 anisotropy_at(vec2 k, vec3 g_n, vec3 n) {
    vec4 ts = anisotropy_decode(k, normalize(g_n));
    vec3 t = ts.xyz - n * dot(n, ts.xyz);
    t = dot(t, t) > 1e-12 ? normalize(t) : tangent_to_world(vec3(1.0, 0.0, 0.0), n);
    return vec4(t, ts.w);
}

// The scene's lights (LIGHT_COUNT): the sum of anisotropy_specular_delta x spec_scale x their
// irradiance at p, shadowed as lights_ggx shadows them.
vec3 lights_anisotropy(vec3 f0, float f90, vec3 spec_scale, vec3 n, vec3 t, vec3 v,
                       vec2 alphas, vec3 p) {
    vec3 c = vec3(0.0);
#if LIGHT_COUNT > 0
#define LIGHT_ANISOTROPY(i) {                                                                 \
        vec4 la = scene_light(i, p, n);                                                     \
        if (la.w > 0.0) c += anisotropy_specular_delta(f0, f90, n, t, v, la.xyz, alphas)     \
                             * u_light_intensity[i] * la.w;                                 \
    }
    FOR_EACH_LIGHT(LIGHT_ANISOTROPY)
#undef LIGHT_ANISOTROPY
#endif
    return c * spec_scale;
}

// The environment's compact lights besides the sun (ENV_LIGHTS), as env_lights_ggx shades
// them, their specular share w.
vec3 env_lights_anisotropy(vec3 f0, float f90, vec3 spec_scale, vec3 n, vec3 t, vec3 v,
                           vec2 alphas, float w, vec3 p) {
    vec3 c = vec3(0.0);
#if ENV_LIGHTS > 0
#define ENV_LIGHT_ANISOTROPY(i) {                                                             \
        vec3 l = rotate_y(u_env_light_direction[i], u_env_rotation);                        \
        vec4 disc = disc_light(n, l, u_env_light_radius[i]);                                \
        if (disc.w > 0.0) {                                                                 \
            c += anisotropy_specular_delta(f0, f90, n, t, v, disc.xyz, alphas)               \
                 * u_env_light_irradiance[i] * (u_env_intensity * disc.w                     \
                 * env_light_visibility(i, p, n, l));                                       \
        }                                                                                   \
    }
    ENV_LIGHT_ANISOTROPY(0)
#if ENV_LIGHTS > 1
    ENV_LIGHT_ANISOTROPY(1)
#endif
#if ENV_LIGHTS > 2
    ENV_LIGHT_ANISOTROPY(2)
#endif
#undef ENV_LIGHT_ANISOTROPY
#endif
    return c * (spec_scale * w);
}
#endif

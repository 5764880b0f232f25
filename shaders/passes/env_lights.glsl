// env_lights.glsl (pass chunk) - the environment's compact lights besides its sun
// (viewer/environment/sun.py extract_lights: a studio's lamps, a second bright window), shaded as the sun is
// (SUN_LIGHT): ggx_environment_sun with the same specular share w, since the prefiltered lookup
// mixes the whole environment's chain back in for all of them with that one weight
// (lib/ibl.glsl ibl_specular_radiance_sun; IBL.bind sets u_sun_radius to the widest light's
// radius). Their diffuse light is whole here: the irradiance map bound leaves them out.
// ENV_LIGHTS: how many (0 compiles everything out); with SUN_SHADOW each reads its own shadow map
// (viewer/graph/frame.py: shadowenv<i>). Included after passes/lights.glsl.
#ifndef ENV_LIGHTS
#define ENV_LIGHTS 0
#endif

#if ENV_LIGHTS > 0
uniform vec3 u_env_light_direction[ENV_LIGHTS];   // unit, towards the light, environment frame
uniform vec3 u_env_light_irradiance[ENV_LIGHTS];  // on a surface facing it (before intensity)
uniform float u_env_light_radius[ENV_LIGHTS];     // angular radius, radians (lib disc_light)
#if SUN_SHADOW
// per light: its map, world -> (u, v, depth), world normal -> map-space plane normal, and
// (angular radius, depth range, extent, normal offset), as u_sun_shadow_* (passes/lights.glsl)
uniform sampler2D u_env_light_shadow_map[ENV_LIGHTS];
uniform mat4 u_env_light_shadow_matrix[ENV_LIGHTS];
uniform mat3 u_env_light_shadow_normal_matrix[ENV_LIGHTS];
uniform vec4 u_env_light_shadow_params[ENV_LIGHTS];
#endif
#endif

// The fraction of environment light i (unit l towards it, world space) reaching p (normal n):
// its shadow map's PCSS visibility with SUN_SHADOW, else 1.
float env_light_visibility(int i, vec3 p, vec3 n, vec3 l) {
#if ENV_LIGHTS > 0 && SUN_SHADOW
    vec4 sp = u_env_light_shadow_params[i];
    vec3 s = (u_env_light_shadow_matrix[i] * vec4(shadow_receiver(p, n, l, sp.w), 1.0)).xyz;
    vec2 dz = shadow_depth_slope(u_env_light_shadow_normal_matrix[i] * n);
    return shadow_visibility(u_env_light_shadow_map[i], s, dz, sp.x, sp.y, sp.z,
                             shadow_phi(gl_FragCoord.xy));
#else
    return 1.0;
#endif
}

// Every such light through ggx_environment_sun (their sum; 0 without ENV_LIGHTS) as the disc it
// is (disc_light: cut by the horizon), rotated and scaled with the environment (u_env_rotation,
// u_env_intensity) and shadowed (env_light_visibility) at the surface point p.
vec3 env_lights_ggx(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter,
                    vec3 n, vec3 v, float w, vec3 p) {
    vec3 c = vec3(0.0);
#if ENV_LIGHTS > 0
    // unrolled, as passes/lights.glsl's FOR_EACH_LIGHT: each light's shadow map one sampler
#define ENV_LIGHT_GGX(i) {                                                                    \
        vec3 l = rotate_y(u_env_light_direction[i], u_env_rotation);                        \
        vec4 disc = disc_light(n, l, u_env_light_radius[i]);                                \
        if (disc.w > 0.0) {                                                                 \
            c += ggx_environment_sun(diffuse, f0, f90, a, dfg, multiscatter, n, v, disc.xyz, \
                                     u_env_light_irradiance[i] * (u_env_intensity * disc.w   \
                                     * env_light_visibility(i, p, n, l)), w);                \
        }                                                                                   \
    }
    ENV_LIGHT_GGX(0)
#if ENV_LIGHTS > 1
    ENV_LIGHT_GGX(1)
#endif
#if ENV_LIGHTS > 2
    ENV_LIGHT_GGX(2)
#endif
#if ENV_LIGHTS > 3
#error "ENV_LIGHTS > 3: unroll env_lights_ggx further (viewer/environment/sun.py ENV_MAX_LIGHTS)"
#endif
#undef ENV_LIGHT_GGX
#endif
    return c;
}

// env_lights_ggx under a KHR_materials_sheen sheen (colour, roughness r, albedo e_v at n.v):
// each light's share of the base scaled by sheen_scaling at its own n.l, plus what the sheen
// reflects of it (lib/layers.glsl sheen_light); as passes/lights.glsl lights_ggx_sheen.
vec3 env_lights_ggx_sheen(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter,
                          vec3 n, vec3 v, float w, vec3 p, vec3 color, float r, float e_v) {
    vec3 c = vec3(0.0);
#if ENV_LIGHTS > 0
#define ENV_LIGHT_SHEEN(i) {                                                                  \
        vec3 l = rotate_y(u_env_light_direction[i], u_env_rotation);                        \
        vec4 disc = disc_light(n, l, u_env_light_radius[i]);                                \
        if (disc.w > 0.0) {                                                                 \
            vec3 e = u_env_light_irradiance[i]                                              \
                     * (u_env_intensity * disc.w * env_light_visibility(i, p, n, l));        \
            c += ggx_environment_sun(diffuse, f0, f90, a, dfg, multiscatter, n, v, disc.xyz, \
                                     e, w)                                                  \
                 * sheen_scaling(color, e_v, sheen_albedo(dot(n, disc.xyz), r))              \
                 + sheen_light(color, r, n, v, disc.xyz) * e;                               \
        }                                                                                   \
    }
    ENV_LIGHT_SHEEN(0)
#if ENV_LIGHTS > 1
    ENV_LIGHT_SHEEN(1)
#endif
#if ENV_LIGHTS > 2
    ENV_LIGHT_SHEEN(2)
#endif
#undef ENV_LIGHT_SHEEN
#endif
    return c;
}

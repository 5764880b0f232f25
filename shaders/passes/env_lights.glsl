// env_lights.glsl (pass chunk) - the environment's compact lights besides its sun
// (viewer/sun.py extract_lights: a studio's lamps, a second bright window), shaded as the sun is
// (SUN_LIGHT): ggx_environment_sun with the same specular share w, since the prefiltered lookup
// mixes the whole environment's chain back in for all of them with that one weight
// (lib/ibl.glsl ibl_specular_radiance_sun; IBL.bind sets u_sun_radius to the widest light's
// radius). Their diffuse light is whole here: the irradiance map bound leaves them out.
// ENV_LIGHTS: how many (0 compiles everything out). Included after lib/shading.glsl.
#ifndef ENV_LIGHTS
#define ENV_LIGHTS 0
#endif

#if ENV_LIGHTS > 0
uniform vec3 u_env_light_direction[ENV_LIGHTS];   // unit, towards the light, environment frame
uniform vec3 u_env_light_irradiance[ENV_LIGHTS];  // on a surface facing it (before intensity)
uniform float u_env_light_radius[ENV_LIGHTS];     // angular radius, radians (lib disc_light)
#endif

// Every such light through ggx_environment_sun (their sum; 0 without ENV_LIGHTS) as the disc it
// is (disc_light: cut by the horizon), rotated and scaled with the environment (u_env_rotation,
// u_env_intensity); nothing shadows them.
vec3 env_lights_ggx(vec3 diffuse, vec3 f0, float a, vec2 dfg, float multiscatter, vec3 n, vec3 v,
                    float w) {
    vec3 c = vec3(0.0);
#if ENV_LIGHTS > 0
    for (int i = 0; i < ENV_LIGHTS; ++i) {
        vec4 disc = disc_light(n, rotate_y(u_env_light_direction[i], u_env_rotation),
                               u_env_light_radius[i]);
        c += ggx_environment_sun(diffuse, f0, a, dfg, multiscatter, n, v, disc.xyz,
                                 u_env_light_irradiance[i] * (u_env_intensity * disc.w), w);
    }
#endif
    return c;
}

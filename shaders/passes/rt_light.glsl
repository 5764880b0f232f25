// rt_light.glsl (pass chunk) - what a shading pass takes from the real-time tier's rays
// (RT_LIGHT; the targets of passes/rt_light.frag after accumulation and filtering): its
// environment terms scaled by the share of the environment the rays see and the light their
// hits bring back added (one bounce). Included by the lighting passes after deferred.glsl.
#ifndef RT_LIGHT
#define RT_LIGHT 0
#endif
#if RT_LIGHT
uniform sampler2D u_rt_light0;  // (diffuse seen, diffuse all, specular seen, specular all)
#if !RT_SUN  // else declared by passes/lights.glsl for the sun's visibility (its alpha)
uniform sampler2D u_rt_light1;  // the diffuse rays' bounce (cosine-weighted mean radiance)
#endif
uniform sampler2D u_rt_light2;  // the specular ray's bounce (radiance)

float rt_ratio(float seen, float all_light) {
    return all_light > 1e-8 ? clamp(seen / all_light, 0.0, 1.0) : 1.0;
}
#endif

// The irradiance a surface at `pixel` receives from the environment and the first bounce: the
// irradiance map's, times the visible share, plus pi times the bounce's mean radiance.
vec3 rt_diffuse_irradiance(ivec2 pixel, vec3 irradiance) {
#if RT_LIGHT
    vec4 r = texelFetch(u_rt_light0, pixel, 0);
    return irradiance * rt_ratio(r.x, r.y) + PI * texelFetch(u_rt_light1, pixel, 0).rgb;
#else
    return irradiance;
#endif
}

// The prefiltered radiance the specular lobe gathers, likewise.
vec3 rt_specular_radiance(ivec2 pixel, vec3 prefiltered) {
#if RT_LIGHT
    vec4 r = texelFetch(u_rt_light0, pixel, 0);
    // target 2: (radiance x w, w), w = 1 where the ratio above holds the lobe's share and the
    // Monte Carlo weights of a wide lobe (passes/rt_light.frag) where it is 0; those weights
    // are F x G2 / G1 >= ~0.04 x 0.5 for any ray above the surface, so a mean under 1e-4 means
    // no ray of the window and the filter's footprint left the surface (no light to divide)
    vec4 b = texelFetch(u_rt_light2, pixel, 0);
    return prefiltered * rt_ratio(r.z, r.w) + (b.a > 1e-4 ? b.rgb / b.a : vec3(0.0));
#else
    return prefiltered;
#endif
}

// lights.glsl (pass chunk) - the scene's punctual lights as uniform arrays and every model's sum
// over them. Included by the lighting passes after lib/shading.glsl (and so by the forward pass of
// transparent surfaces, which compiles the same passes). The maths is lib/lights.glsl.
// LIGHT_COUNT: the number of lights (0 compiles everything out; at most viewer.lighting.lights.MAX_LIGHTS);
// LIGHT_POSITIONAL: 1 when one of them is a point or spot light (the surface position is then
// rebuilt from the G-buffer's depth); LIGHT_SHADOWS / SUN_SHADOW: lights / the environment's sun
// read shadow maps (viewer/passes/shadow.py). Uniforms are set by viewer/passes/shade.py.
#include "lib/layers.glsl"
#ifndef LIGHT_COUNT
#define LIGHT_COUNT 0
#endif
#ifndef LIGHT_POSITIONAL
#define LIGHT_POSITIONAL 0
#endif
#ifndef LIGHT_SHADOWS
#define LIGHT_SHADOWS 0  // 1: some light reads a shadow map (viewer/passes/shadow.py)
#endif

#ifndef SUN_SHADOW
#define SUN_SHADOW 0  // 1: the environment's sun (SUN_LIGHT) reads a shadow map
#endif
#ifndef LIGHT_CASCADES
#define LIGHT_CASCADES 0  // 1: some directional light's map is cascaded (viewer/lighting/cascades.py)
#endif
#ifndef SUN_CASCADES
#define SUN_CASCADES 0  // 1: the sun's map is cascaded
#endif
#ifndef ENV_SHADOWS
#define ENV_SHADOWS 0  // the environment's shadow directions (env_shadow); 0: none
#endif
#ifndef RAYTRACED
#define RAYTRACED 0  // 1: the pass traces rays from surface points (shade_path.frag)
#endif
#if LIGHT_CASCADES || SUN_CASCADES || ENV_SHADOWS > 0
#define SHADOW_CASCADE_MAPS 1
#endif
#if LIGHT_SHADOWS || SUN_SHADOW || ENV_SHADOWS > 0
#include "lib/shadow.glsl"
#endif
#ifndef CONTACT_SHADOWS
#define CONTACT_SHADOWS 0  // 1: screen-space contact shadows ([render] contact_shadows)
#endif
#if LIGHT_POSITIONAL || LIGHT_SHADOWS || SUN_SHADOW || CONTACT_SHADOWS || ENV_SHADOWS > 0 || RAYTRACED
uniform vec3 u_camera_position;                // world space
#endif

// The surface's world position from its view depth (the G-buffer's depth channel: positive
// distance along the view axis) at fragment frag_coord; 0 without positional lights, shadow
// maps or rays.
vec3 light_surface_position(vec2 frag_coord, float depth) {
#if LIGHT_POSITIONAL || LIGHT_SHADOWS || SUN_SHADOW || CONTACT_SHADOWS || ENV_SHADOWS > 0 || RAYTRACED
    vec2 ndc = frag_coord / u_resolution * 2.0 - 1.0;
    return u_camera_position + u_camera_to_world * vec3(ndc * u_tan_half_fov, -1.0) * depth;
#else
    return vec3(0.0);
#endif
}

#if SUN_SHADOW
uniform sampler2D u_sun_shadow_map;
uniform mat4 u_sun_shadow_matrix;         // world -> (u, v, depth)
uniform mat3 u_sun_shadow_normal_matrix;  // world normal -> map-space plane normal
uniform vec4 u_sun_shadow_params;         // angular radius, depth range, extent, normal offset

#if SUN_CASCADES
uniform vec4 u_sun_shadow_cascades[SHADOW_MAX_CASCADES];  // (scale, u0, v0, 0): shadow_cascade_uv
uniform int u_sun_shadow_cascade_count;
#endif

// The fraction of the environment's sun (unit l towards it, world space) reaching p (normal n).
float sun_visibility(vec3 p, vec3 n, vec3 l) {
    vec4 sp = u_sun_shadow_params;
#if SUN_CASCADES
    vec4 lens = vec4(1.0, tan(clamp(sp.x, 0.0, 0.3)) / sp.z, 0.0, sp.y);
    return shadow_cascade_visibility(u_sun_shadow_map, u_sun_shadow_matrix, lens, sp.w,
                                     u_sun_shadow_cascades[0], u_sun_shadow_cascades[1],
                                     u_sun_shadow_cascades[2], u_sun_shadow_cascades[3],
                                     u_sun_shadow_cascade_count, l, p, n,
                                     shadow_phi(gl_FragCoord.xy), false);
#endif
    vec3 q = shadow_receiver(p, n, l, sp.w);
    vec3 s = (u_sun_shadow_matrix * vec4(q, 1.0)).xyz;
    vec2 dz = shadow_depth_slope(u_sun_shadow_normal_matrix * n);
    return shadow_visibility(u_sun_shadow_map, s, dz, sp.x, sp.y, sp.z,
                             shadow_phi(gl_FragCoord.xy));
}
#endif

#if ENV_SHADOWS > 0
// the environment's light as ENV_SHADOWS directional lights (viewer/environment/sampling.py median_cut),
// each with a tile of one shadow atlas (viewer/passes/shadow_bindings.py): per direction its
// tile's world -> (u, v, depth), (unit direction towards it in world space, its share of the
// light), lens (shadow_penumbra_uv) and normal offset
uniform sampler2D u_env_shadow_map;
uniform mat4 u_env_shadow_matrix[ENV_SHADOWS];
uniform vec4 u_env_shadow_dir[ENV_SHADOWS];
uniform vec4 u_env_shadow_lens[ENV_SHADOWS];
uniform float u_env_shadow_offset[ENV_SHADOWS];
#endif

// The fraction of the environment's diffuse light (what the irradiance map holds) reaching the
// pixel whose G-buffer is g (normal n) past the scene's occluders (ENV_SHADOWS; 1 without): the
// mean of the shadow directions' visibilities (shadow_tile_visibility) weighted by the light each
// brings to a surface facing n, its share times max(n.l, 0). Where nothing occludes, exactly 1.
float env_shadow(GBuffer g, vec3 n) {
#if ENV_SHADOWS > 0
    vec3 p = light_surface_position(gl_FragCoord.xy, g.depth);
    float phi = shadow_phi(gl_FragCoord.xy);
    float total = 0.0;
    float seen = 0.0;
    for (int k = 0; k < ENV_SHADOWS; ++k) {
        vec4 d = u_env_shadow_dir[k];
        float w = d.w * max(dot(n, d.xyz), 0.0);
        if (!(w > 0.0)) continue;
        total += w;
        seen += w * shadow_tile_visibility(u_env_shadow_map, u_env_shadow_matrix[k],
                                           u_env_shadow_lens[k], u_env_shadow_offset[k], k,
                                           d.xyz, p, n, phi);
    }
    return total > 0.0 ? seen / total : 1.0;
#else
    return 1.0;
#endif
}

#ifndef RT_SUN
#define RT_SUN 0  // 1: the sun's visibility comes from the real-time tier's rays (rt_light.frag)
#endif
#if RT_SUN
uniform sampler2D u_rt_light1;  // a: the sun's visibility, accumulated (passes/rt_light.glsl)
#endif

// The sun's visibility at the pixel whose G-buffer is g (RT_SUN: traced; SUN_SHADOW: its map;
// 1 without either).
float sun_shadow(GBuffer g, vec3 n, vec3 l) {
#if RT_SUN
    return texelFetch(u_rt_light1, ivec2(gl_FragCoord.xy), 0).a;
#elif SUN_SHADOW
    return sun_visibility(light_surface_position(gl_FragCoord.xy, g.depth), n, l);
#else
    return 1.0;
#endif
}

#if LIGHT_COUNT > 0
#include "lib/lights.glsl"

uniform int u_light_type[LIGHT_COUNT];         // LIGHT_TYPE_* of lib/lights.glsl
uniform vec3 u_light_direction[LIGHT_COUNT];   // unit, towards the light (world space)
uniform vec3 u_light_position[LIGHT_COUNT];    // world space (point, spot)
uniform vec3 u_light_intensity[LIGHT_COUNT];   // colour x intensity: W/m^2 (directional), W/sr
uniform vec4 u_light_cone_range[LIGHT_COUNT];  // (cos outer, cos inner, range or 0, 0)
#if LIGHT_SHADOWS
// per light (viewer/passes/shade.py): its map (a 1x1 map of depth 1 for lights without one), the
// map's world -> (u w, v w, depth, w) (unused by a cube map), its lens (kind: 0 none, SHADOW_ORTHO,
// SHADOW_PERSPECTIVE, SHADOW_CUBE; light-size scale, near, depth range: shadow_penumbra_uv) and
// normal offset (shadow_light_visibility)
uniform sampler2D u_shadow_map[LIGHT_COUNT];
uniform mat4 u_shadow_matrix[LIGHT_COUNT];
uniform vec4 u_shadow_lens[LIGHT_COUNT];
uniform float u_shadow_offset[LIGHT_COUNT];
#if LIGHT_CASCADES
// per light: its cascades' boxes (shadow_cascade_uv; 4 a light) and count (0: one map)
uniform vec4 u_shadow_cascades[LIGHT_COUNT * SHADOW_MAX_CASCADES];
uniform int u_shadow_cascade_count[LIGHT_COUNT];
#endif
#endif

#if CONTACT_SHADOWS
#include "lib/contact.glsl"
#define CONTACT_STEPS 12
uniform float u_contact_length;  // world units the march covers

// 0 where the march from p (normal n) towards the light (unit l) meets, within u_contact_length,
// a sample hidden behind what the G-buffer's depth shows (contact_occluded), else 1. What the
// buffer shows is assumed half the march's length thick, or twice the march's change of depth
// per step where that is more (Filament's thickness, which alone misses a march entering an
// object from its hidden side), so a march passing far behind an object is not taken for a
// hit; the march starts two pixels' width off the surface (a sample on the surface itself would
// read the neighbouring pixels' depths as occluders), each sample's bias is a pixel's width at
// its depth, and the samples are offset per pixel by contact_jitter of a step.
float contact_shadow(vec3 p, vec3 n, vec3 l) {
    mat3 cw = u_camera_to_world;
    vec3 c = contact_project(p, cw[0], cw[1], cw[2], u_camera_position, u_tan_half_fov,
                             u_resolution);
    float pixel = 2.0 * u_tan_half_fov.y / u_resolution.y;  // a pixel's width per unit depth
    vec3 start = p + n * (2.0 * pixel * c.z);
    float step_ws = u_contact_length / float(CONTACT_STEPS);
    float thickness = max(2.0 * abs(dot(l, cw[2])) * step_ws,
                          0.5 * u_contact_length);
    float jitter = contact_jitter(gl_FragCoord.xy);
    for (int k = 0; k < CONTACT_STEPS; ++k) {
        vec3 s = contact_project(start + l * ((float(k) + jitter) * step_ws), cw[0], cw[1],
                                 cw[2], u_camera_position, u_tan_half_fov, u_resolution);
        if (s.z <= 0.0 || any(lessThan(s.xy, vec2(0.0))) ||
            any(greaterThanEqual(s.xy, u_resolution))) break;
        float scene = gbuffer_load(ivec2(s.xy)).depth;
        float bias = pixel * s.z;
        if (contact_occluded(s.z, scene, bias, max(thickness, 2.0 * bias)) > 0.5) return 0.0;
    }
    return 1.0;
}
#endif

// The fraction of light i that reaches the surface point p (normal n, world space; l towards the
// light): its shadow map's PCSS visibility (lib/shadow.glsl) where it has one, times the contact
// shadow (CONTACT_SHADOWS), else 1.
float light_visibility(int i, vec3 p, vec3 n, vec3 l) {
    float v = 1.0;
#if LIGHT_SHADOWS
#if LIGHT_CASCADES
    int nc = u_shadow_cascade_count[i];
    if (nc > 0) {
        int c = i * SHADOW_MAX_CASCADES;
        v = shadow_cascade_visibility(u_shadow_map[i], u_shadow_matrix[i], u_shadow_lens[i],
                                      u_shadow_offset[i], u_shadow_cascades[c],
                                      u_shadow_cascades[c + 1], u_shadow_cascades[c + 2],
                                      u_shadow_cascades[c + 3], nc, l, p, n,
                                      shadow_phi(gl_FragCoord.xy), true);
    } else
#endif
    v = shadow_light_visibility(u_shadow_map[i], u_shadow_matrix[i], u_shadow_lens[i],
                                u_shadow_offset[i], u_light_position[i], l, p, n,
                                shadow_phi(gl_FragCoord.xy));
#endif
#if CONTACT_SHADOWS
    if (v > 0.0 && dot(n, l) > 0.0) v *= contact_shadow(p, n, l);
#endif
    return v;
}

// Light i at p: (l, irradiance scale): punctual_light's attenuation times light_visibility;
// 0 where the surface faces away from the light (n.l <= 0: every BRDF of lights_* is 0 there),
// without a shadow lookup.
vec4 scene_light(int i, vec3 p, vec3 n) {
    vec4 la = punctual_light(u_light_type[i], u_light_position[i], u_light_direction[i],
                             u_light_cone_range[i], p);
    if (!(dot(n, la.xyz) > 0.0)) la.w = 0.0;
    else if (la.w > 0.0) la.w *= light_visibility(i, p, n, la.xyz);
    return la;
}

// FOR_EACH_LIGHT(S): S(0) S(1) ... S(LIGHT_COUNT - 1), the lights' loop unrolled so that each
// light's index is a constant: its shadow map u_shadow_map[i] is then one sampler, where a loop
// variable would index the sampler array at every texture read (on llvmpipe a switch over all
// the maps per read: a fifth of a four-light frame's shadow lookups). One copy of a light's
// code per light.
#if LIGHT_COUNT >= 8
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2) S(3) S(4) S(5) S(6) S(7)
#elif LIGHT_COUNT == 7
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2) S(3) S(4) S(5) S(6)
#elif LIGHT_COUNT == 6
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2) S(3) S(4) S(5)
#elif LIGHT_COUNT == 5
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2) S(3) S(4)
#elif LIGHT_COUNT == 4
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2) S(3)
#elif LIGHT_COUNT == 3
#define FOR_EACH_LIGHT(S) S(0) S(1) S(2)
#elif LIGHT_COUNT == 2
#define FOR_EACH_LIGHT(S) S(0) S(1)
#else
#define FOR_EACH_LIGHT(S) S(0)
#endif

// Every light through ggx_directional_light (Cook-Torrance GGX + Lambert with ggx_split_sum's
// energy split): the BRDF the environment sees in ggx_split_sum, ggx_mc and the split students.
vec3 lights_ggx(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter, vec3 n,
                vec3 v, vec3 p) {
    vec3 c = vec3(0.0);
#define LIGHT_GGX(i) {                                                                        \
        vec4 la = scene_light(i, p, n);                                                     \
        if (la.w > 0.0) c += ggx_directional_light(diffuse, f0, f90, a, dfg, multiscatter, n, \
                                                   v, la.xyz, u_light_intensity[i] * la.w); \
    }
    FOR_EACH_LIGHT(LIGHT_GGX)
#undef LIGHT_GGX
    return c;
}

// Every light on a KHR_materials_clearcoat coat of weight w (lib/layers.glsl clearcoat_light), its
// normal n and alpha a: what the coat reflects of the lights (the base's share is scaled by 1 - w
// by the caller).
vec3 lights_clearcoat(float w, float a, vec3 n, vec3 v, vec3 p) {
    vec3 c = vec3(0.0);
#define LIGHT_CLEARCOAT(i) {                                                                  \
        vec4 la = scene_light(i, p, n);                                                     \
        if (la.w > 0.0) c += clearcoat_light(w, a, n, v, la.xyz) * u_light_intensity[i]     \
                             * la.w;                                                        \
    }
    FOR_EACH_LIGHT(LIGHT_CLEARCOAT)
#undef LIGHT_CLEARCOAT
    return c;
}

// lights_ggx under a KHR_materials_sheen sheen of colour `color`, roughness r and albedo e_v at
// n.v (lib/layers.glsl): each light's share of the base scaled by the spec's albedo scaling at
// its own n.l (sheen_scaling: the exact min form), plus what the sheen reflects of it.
vec3 lights_ggx_sheen(vec3 diffuse, vec3 f0, float f90, float a, vec2 dfg, float multiscatter,
                      vec3 n, vec3 v, vec3 p, vec3 color, float r, float e_v) {
    vec3 c = vec3(0.0);
#define LIGHT_GGX_SHEEN(i) {                                                                  \
        vec4 la = scene_light(i, p, n);                                                     \
        if (la.w > 0.0) {                                                                   \
            vec3 e = u_light_intensity[i] * la.w;                                           \
            c += ggx_directional_light(diffuse, f0, f90, a, dfg, multiscatter, n, v, la.xyz, \
                                       e)                                                   \
                 * sheen_scaling(color, e_v, sheen_albedo(dot(n, la.xyz), r))                \
                 + sheen_light(color, r, n, v, la.xyz) * e;                                 \
        }                                                                                   \
    }
    FOR_EACH_LIGHT(LIGHT_GGX_SHEEN)
#undef LIGHT_GGX_SHEEN
    return c;
}

// Every light through blinn_phong_directional_light (the Blinn-Phong model's BRDF).
vec3 lights_blinn_phong(vec3 diffuse, vec3 f0, float a, vec3 n, vec3 v, vec3 p) {
    vec3 c = vec3(0.0);
#define LIGHT_BLINN_PHONG(i) {                                                                \
        vec4 la = scene_light(i, p, n);                                                     \
        if (la.w > 0.0) c += blinn_phong_directional_light(diffuse, f0, a, n, v, la.xyz,     \
                                                           u_light_intensity[i] * la.w);    \
    }
    FOR_EACH_LIGHT(LIGHT_BLINN_PHONG)
#undef LIGHT_BLINN_PHONG
    return c;
}
#endif

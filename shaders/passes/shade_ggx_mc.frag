// shade_ggx_mc.frag - Monte-Carlo reference of the ggx_split_sum BRDF (Cook-Torrance GGX, height-
// correlated Smith, Schlick Fresnel, optional multiple-scattering compensation; Lambert diffuse
// scaled by 1 - E_spec(n.v) from the DFG LUT, as ggx_split_sum) under the environment (eq. B.4):
//   L_o = 1/N sum_i L(l_i) f(v, l_i) (n.l_i) / p(l_i)
// over samples u_sample_start .. u_sample_start + u_sample_count - 1 of the pixel's scrambled
// (0, 2)-sequence (lib/mc.glsl; a pure function of pixel, sample index and u_seed). Writes the
// mean of this batch; passes/accumulate.frag averages batches. Nothing occludes (single bounce).
// Defines: SAMPLING (0 uniform, 1 cosine, 2 env, 3 brdf, 4 mis), MIS_POWER (1 balance,
// 2 power heuristic), MULTISCATTER, USE_AO, USE_SSAO, BACKGROUND_ENVIRONMENT (0/1
// each), LIGHT_COUNT, LIGHT_POSITIONAL (the punctual lights' terms are analytic, not sampled: main()).
// "mis" draws one BRDF and one environment direction per sample (two evaluations).
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "passes/lights.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/env_sampling.glsl"
#include "passes/surface_mc.glsl"
#include "passes/anisotropy_lights.glsl"

uniform sampler2D u_env_marginal;
uniform sampler2D u_env_conditional;
uniform sampler2D u_env_pdf;
uniform uint u_sample_start;  // index of the first sample of this batch
uniform uint u_sample_count;  // samples in this batch (0 writes the background / black)
uniform uint u_seed;

vec3 env_radiance_ws(vec3 l) {
    return textureLod(u_env_radiance, equirect_uv(env_dir(l)), 0.0).rgb * u_env_intensity;
}

// One sample's estimate; never NaN/Inf (a non-finite value would be a bug; it is dropped).
vec3 estimate(Surface s, uvec2 pixel, uint index) {
    vec2 u0 = mc_sample_2d(pixel.x, pixel.y, index, u_seed, 0u);
    vec3 c = vec3(0.0);
#if SAMPLING == 0 || SAMPLING == 1
#if SAMPLING == 0
    vec3 l = tangent_to_world(sample_uniform_hemisphere(u0), s.n);
    float pdf = 0.5 * INV_PI;
#else
    vec3 l = tangent_to_world(sample_cosine_hemisphere(u0), s.n);
    float pdf = pdf_cosine_hemisphere(dot(s.n, l));
#endif
    if (pdf > 0.0) c = env_radiance_ws(l) * surface_brdf_cos(s, l) / pdf;
#elif SAMPLING == 2
    vec4 e = sample_env(u_env_marginal, u_env_conditional, u_env_pdf, u0);
    vec3 l = rotate_y(e.xyz, u_env_rotation);
    if (e.w > 0.0) c = env_radiance_ws(l) * surface_brdf_cos(s, l) / e.w;
#elif SAMPLING == 3
    vec3 l = sample_surface_brdf(s, u0);
    float pdf = surface_brdf_pdf(s, l);
    if (pdf > 0.0) c = env_radiance_ws(l) * surface_brdf_cos(s, l) / pdf;
#else
    vec3 lb = sample_surface_brdf(s, u0);
    float pb = surface_brdf_pdf(s, lb);
    if (pb > 0.0) {
        float w = mis_weight(pb, env_pdf(u_env_pdf, env_dir(lb)), float(MIS_POWER));
        c += env_radiance_ws(lb) * surface_brdf_cos(s, lb) * (w / pb);
    }
    vec4 e = sample_env(u_env_marginal, u_env_conditional, u_env_pdf,
                        mc_sample_2d(pixel.x, pixel.y, index, u_seed, 1u));
    vec3 le = rotate_y(e.xyz, u_env_rotation);
    if (e.w > 0.0) {
        float w = mis_weight(e.w, surface_brdf_pdf(s, le), float(MIS_POWER));
        c += env_radiance_ws(le) * surface_brdf_cos(s, le) * (w / e.w);
    }
#endif
    bool finite = !any(isnan(c)) && !any(isinf(c));
    return finite ? c : vec3(0.0);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(pixel);
    vec3 d = view_ray_ws(gl_FragCoord.xy);
    vec3 background = background_radiance(d);
    if (g.alpha <= 0.0) {
        write_radiance(vec3(0.0), background, 0.0);
        return;
    }
    vec2 dfg;
    vec4 fresnel = surface_f0_f90(g.albedo, g.metallic, g.specular, g.dielectric);
    Surface s = surface_init(shading_normal(g.normal, -d), -d, g.albedo, g.roughness, g.metallic,
                             fresnel.rgb, fresnel.a, g.clearcoat.xy,
                             shading_normal(oct_decode(g.clearcoat.zw), -d), GBUFFER_SHEEN(g),
                             dfg);
    vec3 f0_lights = s.f0;  // the delta lights' F0 (the split sum's)
#if GBUFFER_HAS_IRIDESCENCE
    surface_set_iridescence(s, g.iridescence, g.clearcoat.x, diffuse_color(g.albedo, g.metallic),
                            dfg);
    f0_lights = iridescence_f0(s.f0, s.f90, s.NoV, s.film, s.film_outside);
#endif
#if GBUFFER_HAS_TRANSMISSION
    // no rays to follow through a transmissive surface: ggx_mc shades its base opaque (a warning)
    surface_set_transmission(s, 0.0, 0.0, false);
#endif
#if GBUFFER_HAS_ANISOTROPY
    vec4 aniso = anisotropy_at(GBUFFER_ANISOTROPY(g), g.normal, s.n);
    surface_set_anisotropy(s, aniso.xyz, aniso.w);
#endif
    s.diffuse *= ambient_occlusion(pixel, g);
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < u_sample_count; ++k) {
        sum += estimate(s, uvec2(pixel), u_sample_start + k);
    }
    vec3 c = sum / float(max(u_sample_count, 1u));
#if LIGHT_COUNT > 0
    // delta lights are not sampled: their terms are added exactly (the function ggx_split_sum
    // uses, on the same diffuse, f0, alpha and DFG terms), to every batch alike
    if (u_sample_count > 0u) {
        vec3 p = light_surface_position(gl_FragCoord.xy, g.depth);
#if GBUFFER_HAS_SHEEN
        // the base under the sheen, light by light (the spec's min form), and the sheen
        vec3 lit = lights_ggx_sheen(diffuse_color(g.albedo, g.metallic), f0_lights, s.f90, s.a, dfg,
                                    float(MULTISCATTER), s.n, s.v, p, s.sheen, s.r_sheen,
                                    s.e_sheen);
#else
        vec3 lit = lights_ggx(diffuse_color(g.albedo, g.metallic), f0_lights, s.f90, s.a, dfg,
                              float(MULTISCATTER), s.n, s.v, p);
#endif
#if GBUFFER_HAS_ANISOTROPY
        if (surface_anisotropic(s)) {
            lit += lights_anisotropy(s.f0, s.f90, s.spec_scale, s.n, s.t, s.v, s.alphas, p);
        }
#endif
#if GBUFFER_HAS_CLEARCOAT
        lit = lit * (1.0 - s.w_c) + lights_clearcoat(s.w_c, s.a_c, s.n_c, s.v, p);
#endif
        c += lit;
    }
#endif
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

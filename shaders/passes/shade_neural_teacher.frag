// shade_neural_teacher.frag - the physics-based neural deferred shader (thesis ch. 4, eq. 4.2) in
// GLSL: for samples u_sample_start .. + u_sample_count - 1 of the pixel's scrambled (0, 2)-sequence
// (lib/mc.glsl, as ggx_mc) draw a light direction l with pdf p, evaluate the generated network
// ("generated/neural_teacher.glsl", from exported weights) and average rho(l) L_i(l) <n.l> / p(l).
// passes/accumulate.frag averages batches (progressive). No shadowing: the teacher is phase 1.
// Defines: SAMPLING (0 uniform hemisphere, 1 cosine, 2 environment importance sampling),
// BACKGROUND_ENVIRONMENT (0/1).
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/shading.glsl"
#include "lib/sampling.glsl"
#include "lib/mc.glsl"
#include "lib/env_sampling.glsl"
#include "generated/neural_teacher.glsl"

uniform sampler2D u_env_marginal;
uniform sampler2D u_env_conditional;
uniform sampler2D u_env_pdf;
uniform uint u_sample_start;
uniform uint u_sample_count;
uniform uint u_seed;

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
    vec3 sum = vec3(0.0);
    for (uint k = 0u; k < u_sample_count; ++k) {
        vec2 u = mc_sample_2d(uint(pixel.x), uint(pixel.y), u_sample_start + k, u_seed, 0u);
#if SAMPLING == 0
        vec3 l = tangent_to_world(sample_uniform_hemisphere(u), n);
        float pdf = 0.5 * INV_PI;
#elif SAMPLING == 1
        vec3 l = tangent_to_world(sample_cosine_hemisphere(u), n);
        float pdf = pdf_cosine_hemisphere(dot(n, l));
#else
        vec4 e = sample_env(u_env_marginal, u_env_conditional, u_env_pdf, u);
        vec3 l = rotate_y(e.xyz, u_env_rotation);
        float pdf = e.w;
#endif
        if (pdf > 0.0) {
            vec3 li = textureLod(u_env_radiance, equirect_uv(env_dir(l)), 0.0).rgb
                      * u_env_intensity;
            sum += neural_teacher_contribution(g.albedo, n, g.roughness, g.metallic, g.specular,
                                               v, l, li) / pdf;
        }
    }
    vec3 c = sum / float(max(u_sample_count, 1u));
    write_radiance(c + emitted_radiance(g), background, g.alpha);
}

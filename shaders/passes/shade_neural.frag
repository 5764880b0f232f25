// shade_neural.frag - the distilled neural shader (learned/neural/student.py): one MLP evaluation
// per pixel on the material, n.v and the pre-integrated lighting (SH irradiance, GGX-prefiltered
// radiance, and the split-sum DFG LUT for students with NEURAL_STUDENT_DFG) every classical model
// reads. The network is generated code baked from an exported weights file (viewer/neural.py ->
// "generated/neural_student.glsl", which defines NEURAL_STUDENT_DFG).
// Defines: USE_AO, USE_SSAO (the occlusion input), BACKGROUND_ENVIRONMENT (0/1).
#include "passes/deferred.glsl"
#include "lib/brdf.glsl"
#include "lib/sh.glsl"
#include "lib/ibl.glsl"
#include "lib/shading.glsl"
#include "generated/neural_student.glsl"

uniform sampler2D u_env_prefiltered;
uniform float u_env_levels;
uniform vec3 u_sh[9];
#if NEURAL_STUDENT_DFG
uniform sampler2D u_env_dfg;
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
    float NoV = saturate(dot(n, v));
    float r = clamp_perceptual_roughness(g.roughness);
    vec3 irradiance = sh_irradiance(env_dir(n), u_sh) * u_env_intensity;
    vec3 prefiltered = ibl_specular_radiance(u_env_prefiltered, env_dir(reflect(-v, n)), r,
                                             u_env_levels) * u_env_intensity;
#if NEURAL_STUDENT_DFG
    vec2 dfg = ibl_dfg(u_env_dfg, NoV, r);
#else
    vec2 dfg = vec2(0.0);
#endif
    float ao = ambient_occlusion(pixel, g);
    vec3 c = neural_student(g.albedo, g.roughness, g.metallic, g.specular, ao, NoV, dfg,
                            irradiance, prefiltered);
    write_radiance(c, background, g.alpha);
}

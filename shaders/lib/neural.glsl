// neural.glsl - building blocks of the generated neural-shader GLSL (viewer/neural/ writes
// "generated/neural_student.glsl" / "generated/neural_teacher.glsl" from exported weights, which
// call these). Pure functions, no uniforms. Twins: learned/twins/neural.py.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/ibl.glsl"

// Scale of the student's sigmoid outputs (learned.neural.student.OUTPUT_SCALE): factors in [0, 2]
// leave room for the indirect light the teacher learned.
#define NEURAL_OUTPUT_SCALE 2.0

// Mildenhall et al. 2020 (NeRF), eq. 4: one Fourier pair (sin(freq x), cos(freq x)) of the
// positional encoding; freq = pi 2^k.
vec2 fourier_feature(float x, float freq) {
    float a = freq * x;
    return vec2(sin(a), cos(a));
}

vec4 relu4(vec4 x) {
    return max(x, vec4(0.0));
}

// Logistic sigmoid 1 / (1 + e^-x), componentwise.
vec4 sigmoid4(vec4 x) {
    return 1.0 / (1.0 + exp(-x));
}

// softplus log(1 + e^x) written as max(x, 0) + log(1 + e^-|x|) so large |x| cannot overflow.
vec4 softplus4(vec4 x) {
    // log(1 + y) with y = e^-|x| in (0, 1], computed as log(u) * y / (u - 1), u = 1 + y
    // (Goldberg 1991): plain log(1 + y) loses all digits of y below 1e-4 (rel. error 1.5e-4
    // measured at x = -6 on llvmpipe); where u rounds to 1, log1p(y) = y.
    vec4 y = exp(-abs(x));
    vec4 u = 1.0 + y;
    vec4 d = u - 1.0;
    vec4 l1p = mix(log(u) * y / max(d, vec4(1e-30)), y, equal(d, vec4(0.0)));
    return max(x, vec4(0.0)) + l1p;
}

// Student radiance, output form "free6" (learned/neural/student.py): six free per-channel factors
// k in [0, 1] of the SH irradiance E and the GGX-prefiltered radiance P,
// L_o = S k_diffuse albedo E / pi + S k_specular P (S = NEURAL_OUTPUT_SCALE). Nothing ties the
// colour to the material: an imperfect network can tint a grey surface.
vec3 neural_student_radiance(vec3 k_diffuse, vec3 k_specular, vec3 albedo, vec3 irradiance,
                             vec3 prefiltered) {
    return NEURAL_OUTPUT_SCALE * k_diffuse * albedo * irradiance * INV_PI
         + NEURAL_OUTPUT_SCALE * k_specular * prefiltered;
}

// Student radiance, output form "pbr3": the split-sum form (Karis 2013; Filament eq. 69
// f0 (dfg.y - dfg.x) + f90 dfg.x) with the three scalars k = (k_d, k_a, k_b) in [0, 1] learned,
// L_o = S k_d diffuse E / pi + S (k_a f0 + k_b f90) P. The colour comes from the material
// (diffuse = diffuse_color, f0 = compute_f0, f90 = f90_from_f0) and the lighting only, so a grey
// material under a grey environment is grey whatever the network learned.
vec3 neural_student_radiance_pbr(vec3 k, vec3 diffuse, vec3 f0, float f90, vec3 irradiance,
                                 vec3 prefiltered) {
    vec3 s = NEURAL_OUTPUT_SCALE * k;
    return s.x * diffuse * irradiance * INV_PI + (s.y * f0 + vec3(s.z * f90)) * prefiltered;
}

// Student radiance, output form "split3": the classical split-sum model (lib/shading.glsl
// ggx_split_sum) with learned achromatic corrections, c = S k in [0, 2]^3:
// L_o = c_d diffuse E / pi (1 - e_spec m) + (c_a f0 (dfg.y - dfg.x) + c_b f90 dfg.x) m P, where
// e_spec = ibl_specular_dfg(dfg, f0, f90), P is read along the dominant direction as
// ggx_split_sum's pass reads it, and m = spec_scale is the multiple-scattering compensation
// (ibl_energy_compensation) for students with NEURAL_STUDENT_MULTISCATTER, 1 otherwise. k = 0.5 is
// ggx_split_sum (with / without multiscatter) exactly, so the network learns only what the
// classical model misses (shadowing, occlusion, inter-reflection, its own bias).
vec3 neural_student_radiance_split(vec3 k, vec3 diffuse, vec3 f0, float f90, vec2 dfg,
                                   vec3 irradiance, vec3 prefiltered, vec3 spec_scale) {
    vec3 s = NEURAL_OUTPUT_SCALE * k;
    vec3 e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale;
    vec3 spec = (s.y * f0 * (dfg.y - dfg.x) + vec3(s.z * f90 * dfg.x)) * spec_scale;
    return s.x * diffuse * irradiance * INV_PI * max(1.0 - e_spec, 0.0) + spec * prefiltered;
}

// The environment's sun under a "split3" student whose base shades it (architecture "sun": true,
// SUN_LIGHT; viewer/environment/sun.py): lib/shading.glsl ggx_environment_sun (its multiple-scattering
// compensation as spec_scale, as in neural_student_radiance_split) with the student's corrections c = S k on the same terms as neural_student_radiance_split,
// F_schlick = f0 (1 - Fc) + f90 Fc split into its f0 and f90 parts:
// L_sun = [c_d diffuse / pi (1 - e_spec m) + (c_a f0 (1 - Fc) + c_b f90 Fc) D V m w] E (n.l),
// Fc = (1 - v.h)^5, w = sun_specular_weight (the rest of the sun's specular light is in the
// prefiltered radiance), E the sun's irradiance; 0 where n.l <= 0. k = 0.5 is
// ggx_environment_sun exactly (multiscatter on where m is its compensation): the diffuse SH
// irradiance and the sun share the correction c_d, so the visibility input can teach the sun's
// shadow.
vec3 neural_student_sun_split(vec3 k, vec3 diffuse, vec3 f0, float f90, vec2 dfg, float a, vec3 n,
                              vec3 v, vec3 l, vec3 irradiance, float specular_weight,
                              vec3 spec_scale) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return vec3(0.0);
    vec3 s = NEURAL_OUTPUT_SCALE * k;
    vec3 h = half_vector(v, l);
    float NoV = saturate(dot(n, v));
    float NoH = saturate(dot(n, h));
    float VoH = saturate(dot(v, h));
    vec3 e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale;
    vec3 fd = s.x * diffuse * INV_PI * max(1.0 - e_spec, 0.0);
    float x = 1.0 - VoH;
    float x2 = x * x;
    float fc = x2 * x2 * x;  // f_schlick's explicit product
    vec3 fresnel = s.y * f0 + (vec3(s.z * f90) - s.y * f0) * fc;
    vec3 fs = d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a) * fresnel * spec_scale;
    return (fd + fs * specular_weight) * irradiance * NoL;
}

// The learned factor on the screen-space indirect light (students with NEURAL_STUDENT_INDIRECT,
// architecture "indirect": "factor"): f = S k in [0, 2] from the sigmoid output k of the
// student's second network ("indirect", generated into neural_student_weights' k_1.x).
// The lighting pass writes it to a second target and passes/ssao.frag (SSAO_INDIRECT_FACTOR)
// scales its one-bounce light by it, L = L_dir + f L_ind; k = 0.5 (the zero-initialised last
// layer) is the classical indirect term, f = 1.
float neural_indirect_factor(float k) {
    return NEURAL_OUTPUT_SCALE * k;
}

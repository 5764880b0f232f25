// brdf.glsl - microfacet and diffuse BRDF terms (Filament naming: NoV, NoL, NoH, VoH).
// Pure functions: no uniforms, no main. Every term is robust for its documented domain:
// dot products in [0, 1] (saturated inside), alpha = perceptual_roughness^2 in [0, 1].
//
// Roughness: the G-buffer stores perceptual roughness r; alpha = r * r. Shading clamps r to
// MIN_PERCEPTUAL_ROUGHNESS = 0.045 (Filament: alpha = 0.002025 keeps D_GGX within fp16/fp32 range
// and avoids a fire-fly mirror spike). The terms below additionally floor alpha^2 at BRDF_MIN_A2 so a
// caller that skips the clamp still gets finite values.
#include "lib/common.glsl"

#define MIN_PERCEPTUAL_ROUGHNESS 0.045
#define BRDF_MIN_A2 1e-8
#define BRDF_MIN_DENOM 1e-8
#define BLINN_PHONG_MAX_SHININESS 16384.0

// Filament "Physically Based Rendering in Filament" sec. 4.8.3.3: clamp perceptual roughness.
float clamp_perceptual_roughness(float perceptual_roughness) {
    return clamp(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
}

// Filament sec. 4.8.3.2: f0 = 0.16 * specular^2 for dielectrics, f0 = base colour for metals.
vec3 compute_f0(vec3 base_color, float metallic, float specular) {
    float f0_dielectric = 0.16 * specular * specular;
    return mix(vec3(f0_dielectric), base_color, saturate(metallic));
}

// Filament sec. 5.6 (specular occlusion from f0): Schlick's grazing reflectance f90, 1 for any
// real material (f0 >= 0.02) and 0 when f0 = 0, so "specular = 0" removes the lobe entirely.
float f90_from_f0(vec3 f0) {
    return saturate(dot(f0, vec3(50.0 * 0.33)));
}

// glTF KHR_materials_ior + KHR_materials_specular: the dielectric lobe's F0 colour,
// min(((ior - 1) / (ior + 1))^2 specular_color, 1) specular_factor (its F90 is specular_factor).
// ior 0 is the extension's "infinite" IOR (F0 = 1). Inputs: ior in {0} or [1, inf), colour and
// factor >= 0 (the factors already times their texture maps).
vec3 dielectric_f0_ior(float ior, vec3 specular_color, float specular_factor) {
    float f0 = ior == 0.0 ? 1.0 : sq((ior - 1.0) / (ior + 1.0));
    return min(vec3(f0) * specular_color, vec3(1.0)) * specular_factor;
}

// The surface's Fresnel terms (f0 in rgb, f90 in a): the G-buffer's optional `dielectric` channel
// (rgb = the dielectric F0, a = its F90, from dielectric_f0_ior) where its a >= 0, metals taking
// F0 = base colour and F90 = 1 (glTF); where a < 0 (its background: surfaces without the
// extensions, and every surface of a scene without its channel) Filament's reflectance,
// compute_f0 and f90_from_f0 of the scalar `specular`, exactly as before.
vec4 surface_f0_f90(vec3 base_color, float metallic, float specular, vec4 dielectric) {
    if (dielectric.a < 0.0) {
        vec3 f0 = compute_f0(base_color, metallic, specular);
        return vec4(f0, f90_from_f0(f0));
    }
    float m = saturate(metallic);
    return vec4(mix(dielectric.rgb, base_color, m), mix(dielectric.a, 1.0, m));
}

// Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 33 (GGX NDF).
float d_ggx(float NoH, float a) {
    // D = a^2 / (pi (NoH^2 (a^2 - 1) + 1)^2), with the bracket written as
    // NoH^2 a^2 + (1 - NoH)(1 + NoH): a sum of non-negative terms, no cancellation near NoH = 1.
    NoH = saturate(NoH);
    float a2 = max(sq(saturate(a)), BRDF_MIN_A2);
    float f = NoH * NoH * a2 + (1.0 - NoH) * (1.0 + NoH);
    return a2 / (PI * f * f);
}

// Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", eq. 99;
// height-correlated Smith-GGX visibility V = G2 / (4 NoV NoL), Filament form.
float v_smith_ggx_correlated(float NoV, float NoL, float a) {
    NoV = saturate(NoV);
    NoL = saturate(NoL);
    float a2 = sq(saturate(a));
    float ggx_v = NoL * sqrt(max(NoV * NoV * (1.0 - a2) + a2, 0.0));
    float ggx_l = NoV * sqrt(max(NoL * NoL * (1.0 - a2) + a2, 0.0));
    return 0.5 / max(ggx_v + ggx_l, BRDF_MIN_DENOM);
}

// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering", eq. 15.
// As f0 (1 - x^5) + f90 x^5 with 1 - x^5 = c (1 + x + x^2 + x^3 + x^4), c = VoH: two terms >= 0,
// so nothing cancels where f0 + (f90 - f0) x^5 would (f90 < f0 and VoH -> 0: an H200 and torch
// then differed by 0.7 % of a GGX lobe whose D V is 1e11).
vec3 f_schlick(vec3 f0, float f90, float VoH) {
    float c = saturate(VoH);
    float x = 1.0 - c;
    float x2 = x * x;
    float x5 = x2 * x2 * x;  // explicit product: pow() is exp2(5 log2 x) and loses precision
    float one_minus_x5 = c * (1.0 + x * (1.0 + x * (1.0 + x * (1.0 + x))));
    return f0 * one_minus_x5 + vec3(f90 * x5);
}

// Lambert 1760; the normalised diffuse BRDF 1/pi (Filament Fd_Lambert).
float fd_lambert() {
    return INV_PI;
}

// Blinn 1977, "Models of Light Reflection for Computer Synthesized Pictures"; energy-normalised
// distribution (s + 2) / (2 pi) NoH^s (Akenine-Moller et al., Real-Time Rendering 4th ed. eq. 9.47).
float d_blinn_phong(float NoH, float shininess) {
    float s = clamp(shininess, 0.0, BLINN_PHONG_MAX_SHININESS);
    // pow(0, 0) is undefined in GLSL (llvmpipe returns 0); a tiny floor makes NoH^0 = 1 everywhere.
    return (s + 2.0) * (0.5 * INV_PI) * pow(max(saturate(NoH), 1e-30), s);
}

// Walter et al. 2007, sec. 5.2: Blinn-Phong exponent matching a GGX/Beckmann alpha, s = 2/a^2 - 2,
// clamped to [0, BLINN_PHONG_MAX_SHININESS] (alpha -> 0 would give an infinite exponent).
float blinn_phong_shininess(float a) {
    float a2 = max(sq(saturate(a)), BRDF_MIN_A2);
    return clamp(2.0 / a2 - 2.0, 0.0, BLINN_PHONG_MAX_SHININESS);
}

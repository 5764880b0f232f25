// layers.glsl - material layers over the base BRDF (glTF PBR extensions). Pure functions: no
// uniforms, no main. Twins: learned/twins/layers.py.
//
// KHR_materials_clearcoat: a GGX coat of IOR 1.5 (F0 = 0.04) with its own perceptual roughness r_c
// and normal n_c, layered by the spec's fresnel_coat: f = mix(f_base, f_coat, c F_c(n_c.v)) with
// F_c Schlick's Fresnel of the coat at n_c.v, f_coat = D_GGX V_SmithGGXCorrelated (no Fresnel of
// its own: fresnel_coat's weight is it), c the clearcoat factor. Its directional albedo is
// c F_c dfg.y <= c F_c, so the layered surface never reflects more than its base would: the base
// keeps 1 - c F_c of everything it reflects.
//
// KHR_materials_sheen: a Charlie sheen lobe (Estevez & Kulla 2017) of colour C and roughness r
// (alpha = r^2, r clamped to [0.07, 1] as three.js does) over the base, layered by the spec's
// albedo scaling: f = f_sheen + (1 - max3(C) max(E(n.v), E(n.l))) f_base, E the sheen's
// directional albedo (lib/sheen_table.glsl; <= 1, so the layered surface never reflects more
// than its base and the sheen's own albedo). Below r = 0.19 the spec's lobe (its fitted Lambda)
// reflects more than it receives at grazing views (up to 1.64): there it is divided by
// N(r) = its largest albedo (sheen_normalization; 1 from r = 0.19 on). The split sum and the punctual lights of
// ggx_split_sum use the spec's cheaper form 1 - max3(C) E(n.v). With a coat too, the coat lies
// over the sheen (the spec). Reference: relight/reference/sheen.py.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/sheen_table.glsl"

#define CLEARCOAT_F0 0.04  // ((1.5 - 1) / (1.5 + 1))^2

// The coat's layering weight c F_c(n_c.v) (KHR_materials_clearcoat fresnel_coat, Schlick 1994):
// what the coat takes of the light, and what the base loses.
float clearcoat_weight(float clearcoat, float NoV) {
    float x = 1.0 - saturate(NoV);
    float x2 = x * x;
    return saturate(clearcoat) * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * (x2 * x2 * x));
}

// The coat under the environment (split sum): its weight w times its GGX lobe's directional
// albedo (the DFG LUT's y at (n_c.v, r_c)) times the radiance prefiltered at r_c along n_c's
// reflection.
vec3 clearcoat_split_sum(float w, vec2 dfg, vec3 prefiltered) {
    return w * dfg.y * prefiltered;
}

// The coat's BRDF times n_c.l for a light from l (unit, world space), 0 below the coat:
// w D_GGX(n_c.h, a_c) V(n_c.v, n_c.l, a_c) n_c.l; the caller multiplies by the light's irradiance.
float clearcoat_light(float w, float a, vec3 n, vec3 v, vec3 l) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return 0.0;
    vec3 h = half_vector(v, l);
    float NoV = saturate(dot(n, v));
    return w * d_ggx(saturate(dot(n, h)), a) * v_smith_ggx_correlated(NoV, NoL, a) * NoL;
}

#define SHEEN_MIN_ROUGHNESS 0.07
#define SHEEN_MIN_COS 1e-4  // cosines floored inside V (relight/reference/sheen.py MIN_COS)

// Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF", eq. 2 (the "Charlie"
// distribution): (2 + 1/a) sin(theta_h)^(1/a) / (2 pi), a = r^2 in [0.0049, 1].
float d_charlie(float NoH, float a) {
    float inv_a = 1.0 / a;
    float sin2h = max(1.0 - NoH * NoH, 0.0);
    return (2.0 + inv_a) * pow(sin2h, 0.5 * inv_a) * (0.5 * INV_PI);
}

// Estevez & Kulla 2017 sec. 3, the fitted exponent of the Charlie Lambda (the glTF spec's
// l(x, alphaG)): a / (1 + b x^c) + d x + e, its coefficients interpolated in (1 - a)^2.
float sheen_lambda_fit(float x, float a) {
    float t = sq(1.0 - a);
    float ca = mix(21.5473, 25.3245, t);
    float cb = mix(3.82987, 3.32435, t);
    float cc = mix(0.19823, 0.16801, t);
    float cd = mix(-1.97760, -1.27393, t);
    float ce = mix(-4.32054, -4.85967, t);
    return ca / (1.0 + cb * pow(x, cc)) + cd * x + ce;
}

// The Charlie Lambda(cos theta) (the spec's lambdaSheen): exp(l(x)) below 0.5, mirrored above.
float sheen_lambda(float cos_theta, float a) {
    float c = abs(cos_theta);
    return c < 0.5 ? exp(sheen_lambda_fit(c, a))
                   : exp(2.0 * sheen_lambda_fit(0.5, a) - sheen_lambda_fit(1.0 - c, a));
}

// The Charlie visibility G / (4 n.v n.l) with G = 1 / (1 + L(n.v) + L(n.l)), clamped at 1 as the
// Khronos sample viewer's V_Sheen (without it the fitted Lambda lets the lobe reflect up to 1.25
// at grazing views); cosines clamped to [SHEEN_MIN_COS, 1].
float v_charlie(float NoV, float NoL, float a) {
    NoV = clamp(NoV, SHEEN_MIN_COS, 1.0);
    NoL = clamp(NoL, SHEEN_MIN_COS, 1.0);
    return min(1.0 / ((1.0 + sheen_lambda(NoV, a) + sheen_lambda(NoL, a)) * (4.0 * NoV * NoL)),
               1.0);
}

// E(n.v, r): the (normalised) sheen lobe's directional albedo (colour 1), bilinear in the table of
// lib/sheen_table.glsl (sqrt(n.v) in [0, 1], r in [0.07, 1], uniform; interpolation error
// -0.007 .. +0.0045: relight/reference/sheen.py TABLE_SIZE).
float sheen_albedo(float NoV, float r) {
    float x = sqrt(saturate(NoV)) * float(SHEEN_TABLE_SIZE - 1);
    float y = (clamp(r, SHEEN_MIN_ROUGHNESS, 1.0) - SHEEN_MIN_ROUGHNESS)
              / (1.0 - SHEEN_MIN_ROUGHNESS) * float(SHEEN_TABLE_SIZE - 1);
    int i = min(int(x), SHEEN_TABLE_SIZE - 2);
    int j = min(int(y), SHEEN_TABLE_SIZE - 2);
    float fx = x - float(i);
    float fy = y - float(j);
    int k = j * SHEEN_TABLE_SIZE + i;
    float lo = mix(SHEEN_ALBEDO_TABLE[k], SHEEN_ALBEDO_TABLE[k + 1], fx);
    float hi = mix(SHEEN_ALBEDO_TABLE[k + SHEEN_TABLE_SIZE],
                   SHEEN_ALBEDO_TABLE[k + SHEEN_TABLE_SIZE + 1], fx);
    return mix(lo, hi, fy);
}

// N(r): what the sheen lobe of roughness r is divided by so that its albedo never exceeds 1
// (1 for r >= 0.19), linear between the table's roughness samples.
float sheen_normalization(float r) {
    float y = (clamp(r, SHEEN_MIN_ROUGHNESS, 1.0) - SHEEN_MIN_ROUGHNESS)
              / (1.0 - SHEEN_MIN_ROUGHNESS) * float(SHEEN_TABLE_SIZE - 1);
    int j = min(int(y), SHEEN_TABLE_SIZE - 2);
    return mix(SHEEN_NORMALIZATION[j], SHEEN_NORMALIZATION[j + 1], y - float(j));
}

// The spec's albedo scaling of the base under a sheen of colour C: 1 - max3(C) max(e_v, e_l)
// (e_v = E(n.v), e_l = E(n.l); e_l = e_v gives its cheaper form).
float sheen_scaling(vec3 color, float e_v, float e_l) {
    return 1.0 - max(max(color.r, color.g), color.b) * max(e_v, e_l);
}

// The sheen under the environment (split sum): C E(n.v, r) times the radiance prefiltered
// at r (Filament's cloth IBL: the Charlie lobe's DFG term is E itself, its Fresnel being 1).
vec3 sheen_split_sum(vec3 color, float e, vec3 prefiltered) {
    return color * e * prefiltered;
}

// The sheen's BRDF times n.l for a light from l (unit, world space), 0 below the surface:
// C D_charlie(n.h) V_charlie(n.v, n.l) n.l / N(r), r its perceptual roughness (clamped here).
vec3 sheen_light(vec3 color, float r, vec3 n, vec3 v, vec3 l) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return vec3(0.0);
    float a = sq(clamp(r, SHEEN_MIN_ROUGHNESS, 1.0));
    vec3 h = half_vector(v, l);
    return color * (d_charlie(saturate(dot(n, h)), a) * v_charlie(saturate(dot(n, v)), NoL, a)
                    * NoL / sheen_normalization(r));
}

// Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit Vectors",
// octahedral encoding: a unit vector as 2 numbers in [-1, 1] (the G-buffer's clearcoat normal).
vec2 oct_encode(vec3 n) {
    vec3 a = abs(n);
    vec2 p = n.xy / max(a.x + a.y + a.z, 1e-30);
    if (n.z < 0.0) {
        p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    }
    return p;
}

// The inverse of oct_encode: a unit vector (a zero encoding decodes to +Z).
vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    }
    return normalize(n);
}

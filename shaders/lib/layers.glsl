// layers.glsl - material layers over the base BRDF (glTF PBR extensions). Pure functions: no
// uniforms, no main. Twins: learned/twins/layers.py.
//
// KHR_materials_clearcoat: a GGX coat of IOR 1.5 (F0 = 0.04) with its own perceptual roughness r_c
// and normal n_c, layered by the spec's fresnel_coat: f = mix(f_base, f_coat, c F_c(n_c.v)) with
// F_c Schlick's Fresnel of the coat at n_c.v, f_coat = D_GGX V_SmithGGXCorrelated (no Fresnel of
// its own: fresnel_coat's weight is it), c the clearcoat factor. Its directional albedo is
// c F_c dfg.y <= c F_c, so the layered surface never reflects more than its base would: the base
// keeps 1 - c F_c of everything it reflects.
#include "lib/common.glsl"
#include "lib/brdf.glsl"

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

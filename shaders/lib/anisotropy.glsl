// anisotropy.glsl - glTF KHR_materials_anisotropy: the anisotropic GGX lobe (Burley 2012's
// stretched GGX, as the extension and Filament write it), its visible-normal sampling, the IBL
// bent normal and the G-buffer encoding of the direction. Pure functions: no uniforms, no main.
// Frame: t = the anisotropy direction (unit, in the tangent plane; the highlight stretches along
// it), b = cross(n, t), n the shading normal; (alpha_t, alpha_b) = (mix(a, 1, s^2), a) for the
// material's alpha a = r^2 and strength s (anisotropy_alphas). With s = 0 every function here
// reduces to its isotropic counterpart in lib/brdf.glsl and lib/mc.glsl.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/sampling.glsl"

#define ANISOTROPY_MIN_ALPHA 1e-4

// KHR_materials_anisotropy: the direction's alpha grows with the strength s in [0, 1],
// alpha_t = mix(a, 1, s^2); the perpendicular keeps the material's alpha_b = a.
vec2 anisotropy_alphas(float a, float strength) {
    float s = saturate(strength);
    return vec2(mix(a, 1.0, s * s), a);
}

// Burley 2012, "Physically Based Shading at Disney", appendix B.2 (anisotropic GGX); the
// extension's D(h) = 1 / (pi at ab ((h.t/at)^2 + (h.b/ab)^2 + (h.n)^2)^2), written as
// a2 w2^2 / pi with a2 = at ab and w2 = a2 / |(ab h.t, at h.b, a2 h.n)|^2 (no 1/alpha^4).
float d_ggx_anisotropic(float NoH, float ToH, float BoH, float at, float ab) {
    at = max(at, ANISOTROPY_MIN_ALPHA);
    ab = max(ab, ANISOTROPY_MIN_ALPHA);
    float a2 = at * ab;
    vec3 f = vec3(ab * ToH, at * BoH, a2 * saturate(NoH));
    float w2 = a2 / max(dot(f, f), 1e-30);
    return a2 * w2 * w2 * INV_PI;
}

// Heitz 2014, "Understanding the Masking-Shadowing Function", eq. 99 with the anisotropic
// Lambda (sec. 5.3): height-correlated V = G2 / (4 NoV NoL) = 0.5 / (NoL |(at ToV, ab BoV, NoV)|
// + NoV |(at ToL, ab BoL, NoL)|), the extension's V_GGX_anisotropic without its clamp to 1
// (v_smith_ggx_correlated has none either: at at = ab both are the same function).
float v_smith_ggx_correlated_anisotropic(float NoV, float NoL, float ToV, float BoV, float ToL,
                                         float BoL, float at, float ab) {
    NoV = saturate(NoV);
    NoL = saturate(NoL);
    float ggx_v = NoL * length(vec3(at * ToV, ab * BoV, NoV));
    float ggx_l = NoV * length(vec3(at * ToL, ab * BoL, NoL));
    return 0.5 / max(ggx_v + ggx_l, BRDF_MIN_DENOM);
}

// Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)), sec. 3 with the
// spherical caps of Dupuy & Benyoub 2023 (as sample_ggx_vndf): v (unit, the (t, b, n) frame,
// z >= 0) stretched by (at, ab), a visible normal of the unit hemisphere, unstretched. Returns
// a unit half vector in the same frame.
vec3 sample_ggx_vndf_anisotropic(vec2 u, vec3 v, float at, float ab) {
    at = max(saturate(at), ANISOTROPY_MIN_ALPHA);
    ab = max(saturate(ab), ANISOTROPY_MIN_ALPHA);
    vec3 vh = normalize(vec3(at * v.x, ab * v.y, max(v.z, 0.0) + 1e-7));
    float phi = TWO_PI * u.x;
    float z = (1.0 - u.y) * (1.0 + vh.z) - vh.z;
    float sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    vec3 hh = vec3(sin_theta * cos(phi), sin_theta * sin(phi), z) + vh;
    vec3 h = vec3(at * hh.x, ab * hh.y, max(hh.z, 0.0));
    float len2 = dot(h, h);
    return len2 > 1e-30 ? h * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
}

// pdf (solid angle, of l = reflect(-v, h)) of sample_ggx_vndf_anisotropic: G1(v) D(h) / (4 n.v)
// = D(h) / (2 (NoV + |(at v.x, ab v.y, NoV)|)); v, h in the (t, b, n) frame; 0 for h below.
float pdf_ggx_vndf_anisotropic(vec3 v, vec3 h, float at, float ab) {
    if (!(h.z > 0.0)) return 0.0;
    float NoV = saturate(v.z);
    float lambda = length(vec3(at * v.x, ab * v.y, NoV));
    return d_ggx_anisotropic(h.z, h.x, h.y, at, ab) / (2.0 * max(NoV + lambda, BRDF_MIN_DENOM));
}

// The extension's (and Filament's, three.js's getIBLAnisotropyRadiance) bent normal for the
// prefiltered lookup: the normal turned towards the plane of b and v, by how much the lobe is
// stretched (strength s, perceptual roughness r). n, b, v unit; returns a unit vector.
vec3 anisotropy_bent_normal(vec3 n, vec3 b, vec3 v, float strength, float roughness) {
    vec3 bent = cross(cross(b, v), b);
    float len2 = dot(bent, bent);
    bent = len2 > 1e-20 ? bent * inversesqrt(len2) : n;
    float k = sq(sq(1.0 - saturate(strength) * (1.0 - saturate(roughness))));
    return normalize(mix(bent, n, k));
}

// The G-buffer's `anisotropy` channel: direction t (unit, in the plane of n) and strength s as
// s (cos phi, sin phi), phi the angle of t in tangent_to_world's frame of n (t and -t are the
// same lobe; s = 0 is the channel's background, no anisotropy).
vec2 anisotropy_encode(vec3 t, vec3 n, float strength) {
    vec3 x = tangent_to_world(vec3(1.0, 0.0, 0.0), n);
    vec3 y = tangent_to_world(vec3(0.0, 1.0, 0.0), n);
    vec2 d = vec2(dot(t, x), dot(t, y));
    float len2 = dot(d, d);
    return len2 > 1e-20 ? d * (saturate(strength) * inversesqrt(len2)) : vec2(0.0);
}

// anisotropy_encode's inverse for the normal n it was encoded with: (t, s), t unit in n's plane
// (the +x axis of n's frame where s = 0).
vec4 anisotropy_decode(vec2 k, vec3 n) {
    float s = length(k);
    vec2 d = s > 1e-20 ? k / s : vec2(1.0, 0.0);
    return vec4(tangent_to_world(vec3(d, 0.0), n), s);
}

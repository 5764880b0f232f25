// iridescence.glsl - KHR_materials_iridescence: the thin-film Fresnel of Belcour & Barla 2017
// in the glTF specification's form (its "Implementation Notes": Schlick interfaces, phases 0 or
// pi, the analytic spectral integration of the first three Fourier terms against the CIE XYZ
// sensitivities, converted to linear Rec.709). Pure functions: no uniforms, no main. Twins:
// learned/twins/iridescence.py; float64 reference: relight/reference/iridescence.py.
//
// A film of IOR eta2 and thickness d (nm) over the base (F0 at normal incidence from air), seen
// from a medium of IOR eta1: 1 (air), or under a KHR_materials_clearcoat coat the coat's 1.5 (the
// spec's "Clearcoat" section: the coat is evaluated before the film, whose outside IOR becomes
// the coat's), mix(1, 1.5, clearcoat factor) for partial coats (OpenPBR's thin_film outside
// IOR, Babylon): iridescence_outside_ior. As three.js does, the film's IOR is blended towards
// the outside's over the first 30 nm (iridescence_film_ior), so a film of thickness 0 is no film:
// the result is then the base's own Schlick Fresnel F0 + (1 - F0)(1 - c)^5. The specification
// mixes it into the surface's Fresnel by the factor (iridescence_fresnel_mix); the split-sum
// model uses the F0 that reproduces it at n.v (iridescence_f0, three.js's approximation).
// (The Fourier series' clamp of R12 R23 at 1e-5 leaves ~0.006 (1 - R23) of interference at
// normal incidence even without a film: so thickness 0 switches the film off, as three.js.)
#include "lib/common.glsl"
#include "lib/brdf.glsl"

#define IRIDESCENCE_FILM_RAMP_NM 30.0  // three.js: smoothstep(0, 0.03 um, d) blends eta2 in
// points of iridescence_albedo_delta's quadrature: its error against the integral is <= 0.009
// (0.038 with 16, 0.059 with 8) over n.v 0.02..1, roughness 0.1..1, films 100..1200 nm of IOR
// 1.3 and 1.8 over F0 0.04 and 0.9 (relight/reference/iridescence.py, 2e5 random points)
#define IRIDESCENCE_ALBEDO_NODES 32
#define IRIDESCENCE_COAT_IOR 1.5  // KHR_materials_clearcoat's coat (lib/layers.glsl: F0 0.04)

// Fresnel's normal-incidence reflectance between media of IOR n_t (transmitted) and n_i
// (incident), ((n_t - n_i) / (n_t + n_i))^2 (the spec's IorToFresnel0).
vec3 ior_to_fresnel0(vec3 n_t, float n_i) {
    vec3 r = (n_t - vec3(n_i)) / (n_t + vec3(n_i));
    return r * r;
}

// The IOR (against air) whose normal-incidence reflectance is f0 (the spec's Fresnel0ToIor;
// f0 is clamped below 1: three.js's guard against an infinite IOR).
// (1 + s) / (1 - s) = (1 + s)^2 / (1 - f0): no 1 - s to cancel near the clamp (1 - f0 is exact
// there), so a sqrt's last ulps are not amplified 2e4 times.
vec3 fresnel0_to_ior(vec3 f0) {
    vec3 f = clamp(f0, vec3(0.0), vec3(0.9999));
    vec3 s1 = vec3(1.0) + sqrt(f);
    return s1 * s1 / (vec3(1.0) - f);
}

// The film's effective IOR: eta2 blended in from the outside's eta1 over the first
// IRIDESCENCE_FILM_RAMP_NM nm of thickness (three.js), so thickness 0 removes the film.
float iridescence_film_ior(float eta1, float eta2, float thickness_nm) {
    return mix(eta1, eta2, smoothstep(0.0, IRIDESCENCE_FILM_RAMP_NM, thickness_nm));
}

// The spec's evalSensitivity: the Fourier transform of the CIE 1931 XYZ sensitivities (a sum of
// Gaussians, Belcour & Barla 2017 sec. 4) at optical path difference opd (nm) with phase shift
// `shift` per channel, divided by the integral of Y (1.0685e-7), in linear Rec.709.
vec3 iridescence_sensitivity(float opd, vec3 shift) {
    float phase = TWO_PI * opd * 1.0e-9;
    vec3 val = vec3(5.4856e-13, 4.4201e-13, 5.2481e-13);
    vec3 pos = vec3(1.6810e+06, 1.7953e+06, 2.2084e+06);
    vec3 var = vec3(4.3278e+09, 9.3046e+09, 6.6121e+09);
    vec3 xyz = val * sqrt(TWO_PI * var) * cos(pos * phase + shift) * exp(-phase * phase * var);
    xyz.x += 9.7470e-14 * sqrt(TWO_PI * 4.5282e+09) * cos(2.2399e+06 * phase + shift.x)
             * exp(-4.5282e+09 * phase * phase);
    xyz /= 1.0685e-7;
    const mat3 XYZ_TO_REC709 = mat3(3.2404542, -0.9692660, 0.0556434,
                                    -1.5371385, 1.8760108, -0.2040259,
                                    -0.4985314, 0.0415560, 1.0572252);
    return XYZ_TO_REC709 * xyz;
}

// Belcour & Barla 2017 (the glTF spec's evalIridescence): the reflectance of a film of IOR
// film_ior and thickness thickness_nm over a base of normal-incidence reflectance base_f0,
// seen at cos theta1 = cos_theta1 from a medium of IOR outside_ior, clamped to [0, 1] (the spec
// clamps at 0 only). Total internal reflection in the film gives 1.
vec3 iridescence_fresnel(float outside_ior, float film_ior, float cos_theta1,
                         float thickness_nm, vec3 base_f0) {
    float c1 = saturate(cos_theta1);
    float eta2 = iridescence_film_ior(outside_ior, film_ior, thickness_nm);
    float sin2_theta2 = sq(outside_ior / eta2) * (1.0 - c1 * c1);
    float cos2_theta2 = 1.0 - sin2_theta2;
    if (cos2_theta2 < 0.0) return vec3(1.0);  // total internal reflection
    float c2 = sqrt(cos2_theta2);
    // first interface (outside -> film)
    float r0 = ior_to_fresnel0(vec3(eta2), outside_ior).x;
    float r12 = f_schlick(vec3(r0), 1.0, c1).x;
    float t121 = 1.0 - r12;
    float phi12 = eta2 < outside_ior ? PI : 0.0;
    float phi21 = PI - phi12;
    // second interface (film -> base)
    vec3 base_ior = fresnel0_to_ior(base_f0);
    vec3 r1 = ior_to_fresnel0(base_ior, eta2);
    vec3 r23 = f_schlick(r1, 1.0, c2);
    vec3 phi23 = vec3(base_ior.x < eta2 ? PI : 0.0, base_ior.y < eta2 ? PI : 0.0,
                      base_ior.z < eta2 ? PI : 0.0);
    // phase shift and the optical path difference
    float opd = 2.0 * eta2 * thickness_nm * c2;
    vec3 phi = vec3(phi21) + phi23;
    // compound terms
    vec3 r123 = clamp(r12 * r23, vec3(1e-5), vec3(0.9999));
    vec3 r123_sqrt = sqrt(r123);
    vec3 rs = sq(t121) * r23 / (vec3(1.0) - r123);
    vec3 i = vec3(r12) + rs;  // m = 0, the DC term
    vec3 cm = rs - vec3(t121);
    for (int m = 1; m <= 2; ++m) {  // m > 0, pairs of Diracs
        cm *= r123_sqrt;
        i += cm * 2.0 * iridescence_sensitivity(float(m) * opd, float(m) * phi);
    }
    // the spec stops at max(I, 0); its Rec.709 interference terms leave the gamut at grazing
    // views over bright bases (I up to 1.75 in red at n.v < 0.1; 0.4 % of films 0..1200 nm,
    // IOR 1..2.5 over F0 = 0.04, 3.8 % over F0 = 0.95): a reflectance never exceeds 1
    return clamp(i, vec3(0.0), vec3(1.0));
}

// The IOR the film is seen from under a coat of factor `clearcoat` (0: none, air):
// mix(1, IRIDESCENCE_COAT_IOR, clearcoat), the coat's IOR under a full coat (the spec's case),
// continuous for partial ones (OpenPBR, Babylon); exactly 1 without a coat.
float iridescence_outside_ior(float clearcoat) {
    return mix(1.0, IRIDESCENCE_COAT_IOR, saturate(clearcoat));
}

// The F0 whose Schlick Fresnel with this f90 gives f at cosine c (three.js's Schlick_to_F0),
// clamped to [0, 1]; at grazing c (1 - (1 - c)^5 -> 0) the denominator is floored at 1e-4.
vec3 schlick_to_f0(vec3 f, float f90, float c) {
    float x = 1.0 - saturate(c);
    float x2 = x * x;
    float x5 = x2 * x2 * x;
    return clamp((f - vec3(f90 * x5)) / max(1.0 - x5, 1e-4), vec3(0.0), vec3(1.0));
}

// The surface's Fresnel with KHR_materials_iridescence (iridescence = (factor, thickness nm,
// film IOR)) at v.h = VoH: mix(F_Schlick(f0, f90, VoH), F_iridescence(VoH), factor), the spec's
// mix, the film seen from a medium of IOR outside_ior (iridescence_outside_ior). The film over
// the base uses f0 as the base's reflectance (the spec: baseF0). A film of thickness 0 is none
// (three.js): F_Schlick exactly.
vec3 iridescence_fresnel_mix(vec3 f0, float f90, float VoH, vec3 iridescence,
                             float outside_ior) {
    vec3 f = f_schlick(f0, f90, VoH);
    if (!(iridescence.x > 0.0 && iridescence.y > 0.0)) return f;
    return mix(f, iridescence_fresnel(outside_ior, iridescence.z, VoH, iridescence.y, f0),
               saturate(iridescence.x));
}

// The split-sum's F0 with the film: mix(f0, Schlick_to_F0(F_iridescence(n.v), f90, n.v),
// factor) (three.js: the thin-film Fresnel at n.v in place of the Schlick F0 term), the film
// seen from outside_ior; f0 itself where the factor or the thickness is 0.
vec3 iridescence_f0(vec3 f0, float f90, float NoV, vec3 iridescence, float outside_ior) {
    if (!(iridescence.x > 0.0 && iridescence.y > 0.0)) return f0;
    vec3 f = iridescence_fresnel(outside_ior, iridescence.z, NoV, iridescence.y, f0);
    return mix(f0, schlick_to_f0(f, f90, NoV), saturate(iridescence.x));
}

// What the film changes in the specular lobe's directional albedo at n.v (alpha a): factor x the
// mean over IRIDESCENCE_ALBEDO_NODES fixed points u_k = ((k + 1/2) / K, frac(k / golden ratio))
// of (F_film - F_Schlick)(v.h) f cos / pdf at the visible normals they draw (lib/mc.glsl
// sample_ggx_vndf's mapping, Dupuy & Benyoub 2023; f cos / pdf = 2 V (n.l) (n.v + sqrt(a^2 +
// (1 - a^2) n.v^2))). Added to the DFG terms' E_spec it is the film's E_spec, which the exact
// models' diffuse keeps 1 - of (the film's Fresnel at n.v alone over-lights the diffuse by up to
// 15 % at grazing views of rough films). The film seen from outside_ior. 0 without a film.
vec3 iridescence_albedo_delta(vec3 f0, float f90, float NoV, float a, vec3 iridescence,
                              float outside_ior) {
    if (!(iridescence.x > 0.0 && iridescence.y > 0.0)) return vec3(0.0);
    float c = saturate(NoV);
    a = clamp(a, 1e-4, 1.0);
    float a2 = a * a;
    float vx = sqrt(max(1.0 - c * c, 0.0));
    vec2 vh = vec2(a * vx, c + 1e-7) * inversesqrt(a2 * vx * vx + sq(c + 1e-7));
    float lam = 2.0 * (c + sqrt(a2 + (1.0 - a2) * c * c));
    vec3 sum = vec3(0.0);
    for (int k = 0; k < IRIDESCENCE_ALBEDO_NODES; ++k) {
        float phi = TWO_PI * (float(k) + 0.5) / float(IRIDESCENCE_ALBEDO_NODES);
        float z = (1.0 - fract(float(k) * 0.6180339887498949)) * (1.0 + vh.y) - vh.y;
        float sin_t = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
        vec3 h = vec3(a * (sin_t * cos(phi) + vh.x), a * sin_t * sin(phi), max(z + vh.y, 0.0));
        h *= inversesqrt(max(dot(h, h), 1e-30));
        float VoH = vx * h.x + c * h.z;
        float NoL = 2.0 * VoH * h.z - c;
        if (!(NoL > 0.0)) continue;
        float w = v_smith_ggx_correlated(c, NoL, a) * NoL * lam;
        sum += (iridescence_fresnel(outside_ior, iridescence.z, VoH, iridescence.y, f0)
                - f_schlick(f0, f90, VoH)) * w;
    }
    return sum * (saturate(iridescence.x) / float(IRIDESCENCE_ALBEDO_NODES));
}

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
#define ANISOTROPY_ALBEDO_GRID 6  // anisotropy_albedo_ratio's quadrature: points a side

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
    // e = 1 + z, d = 1 - vh.z: as sample_ggx_vndf (no cancellation at the cap's rim)
    float d = dot(vh.xy, vh.xy) / (1.0 + vh.z);
    float e = (1.0 - u.y) * (1.0 + vh.z) + d;
    float sin_theta = sqrt(clamp(e * (2.0 - e), 0.0, 1.0));
    vec3 hh = vec3(sin_theta * cos(phi) + vh.x, sin_theta * sin(phi) + vh.y, e - d);
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

// The extension's anisotropyTexture read at a point: RG the direction in tangent space (x 2 - 1;
// unit, or +x where it is zero), turned counter-clockwise by the material's rotation
// (cos, sin); B multiplies the strength. Returns (direction, strength multiplier). Shared by the
// rasteriser (passes/mesh_anisotropy.glsl) and traced hits (passes/raytrace.glsl).
vec3 anisotropy_map_direction(vec2 rotation, vec3 texel) {
    vec2 d = texel.rg * 2.0 - 1.0;
    d = dot(d, d) > 1e-12 ? normalize(d) : vec2(1.0, 0.0);
    vec2 c = rotation;
    return vec3(mat2(c.x, c.y, -c.y, c.x) * d, texel.b);
}

// anisotropy_encode's inverse for the normal n it was encoded with: (t, s), t unit in n's plane
// (the +x axis of n's frame where s = 0).
vec4 anisotropy_decode(vec2 k, vec3 n) {
    float s = length(k);
    vec2 d = s > 1e-20 ? k / s : vec2(1.0, 0.0);
    return vec4(tangent_to_world(vec3(d, 0.0), n), s);
}

// The anisotropic lobe's specular f cos minus that of the isotropic lobe of alpha_b (the
// material's own; same Fresnel) for light l, 0 below the horizon: added to
// ggx_environment_sun's / ggx_directional_light's value (times their specular weight, the
// multiple-scattering compensation and the irradiance), it makes their specular anisotropic.
// n, t, v, l unit, t in n's plane; alphas = anisotropy_alphas.
vec3 anisotropy_specular_delta(vec3 f0, float f90, vec3 n, vec3 t, vec3 v, vec3 l, vec2 alphas) {
    float NoL = dot(n, l);
    if (!(NoL > 0.0)) return vec3(0.0);
    vec3 b = cross(n, t);
    vec3 h = half_vector(v, l);
    float NoV = saturate(dot(n, v));
    float NoH = saturate(dot(n, h));
    float aniso = d_ggx_anisotropic(NoH, dot(t, h), dot(b, h), alphas.x, alphas.y)
                  * v_smith_ggx_correlated_anisotropic(NoV, NoL, dot(t, v), dot(b, v), dot(t, l),
                                                       dot(b, l), alphas.x, alphas.y);
    float iso = d_ggx(NoH, alphas.y) * v_smith_ggx_correlated(NoV, NoL, alphas.y);
    return (aniso - iso) * f_schlick(f0, f90, saturate(dot(v, h))) * NoL;
}

// The anisotropic lobe's directional albedo over the isotropic one's of alpha_b, for white
// Fresnel: E = integral of D V 4 n.v n.l / (4 n.v) ... = the mean of G2(v, l) / G1(v) over the
// visible normals (Heitz 2018, eq. 17), estimated on the same ANISOTROPY_ALBEDO_GRID^2
// stratified points for both lobes (within 4 % of float64 quadratures at r = 0.3, s = 0.8;
// 7-8 % with 4 x 4). The split sum's DFG terms are the isotropic lobe's: this ratio scales its
// environment specular (the stretched lobe loses more light over the horizon: albedo 0.71
// against 0.99 at r = 0.3, s = 0.8, n.v = 1). v in the (t, b, n) frame, z > 0; alphas =
// anisotropy_alphas.
float anisotropy_albedo_ratio(vec3 v, vec2 alphas) {
    float NoV = max(v.z, 1e-4);
    float e_aniso = 0.0;
    float e_iso = 0.0;
    const int g = ANISOTROPY_ALBEDO_GRID;
    for (int k = 0; k < g * g; ++k) {
        vec2 u = (vec2(float(k % g), float(k / g)) + 0.5) / float(g);
        vec3 h = sample_ggx_vndf_anisotropic(u, v, alphas.x, alphas.y);
        vec3 l = reflect(-v, h);
        if (l.z > 0.0) {
            float g1 = 2.0 * NoV / (NoV + length(vec3(alphas.x * v.x, alphas.y * v.y, NoV)));
            e_aniso += 4.0 * NoV * l.z * v_smith_ggx_correlated_anisotropic(
                NoV, l.z, v.x, v.y, l.x, l.y, alphas.x, alphas.y) / g1;
        }
        h = sample_ggx_vndf_anisotropic(u, v, alphas.y, alphas.y);
        l = reflect(-v, h);
        if (l.z > 0.0) {
            float g1 = 2.0 * NoV / (NoV + length(vec3(alphas.y * v.x, alphas.y * v.y, NoV)));
            e_iso += 4.0 * NoV * l.z * v_smith_ggx_correlated_anisotropic(
                NoV, l.z, v.x, v.y, l.x, l.y, alphas.y, alphas.y) / g1;
        }
    }
    return e_iso > 0.0 ? e_aniso / e_iso : 1.0;
}

// mc.glsl - Monte-Carlo integration of the Cook-Torrance GGX + Lambert BRDF against the
// environment: per-pixel scrambled low-discrepancy sequences, hemisphere / GGX-VNDF sampling with
// their pdfs, and MIS weights. Directions are in tangent space (z = normal) unless named _ws.
// No uniforms, no main. Twins: learned/twins/mc.py.
#include "lib/common.glsl"
#include "lib/brdf.glsl"

// ---- random numbers ------------------------------------------------------------------------------

// Wellons 2018, "Prospecting for Hash Functions" (lowbias32): a 32-bit integer hash with good
// avalanche; used to derive per-pixel, per-seed, per-dimension scrambles.
uint hash_u32(uint x) {
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// The scramble of dimension `dim` of pixel (px, py) under `seed`: a pure function of its
// arguments, so the torch twin reproduces every sample of a render.
uint mc_scramble(uint px, uint py, uint seed, uint dim) {
    return hash_u32(px ^ hash_u32(py ^ hash_u32(seed ^ hash_u32(dim + 0x9e3779b9u))));
}

// Kollig & Keller 2002, "Efficient Multidimensional Sampling", sec. 3: the second component of
// the base-2 Sobol' (0, 2)-sequence (generator matrix of Sobol' dimension 2) as 32 bits.
uint sobol2_bits(uint i) {
    uint r = 0u;
    for (uint v = 1u << 31u; i != 0u; i >>= 1u, v ^= v >> 1u) {
        if ((i & 1u) != 0u) {
            r ^= v;
        }
    }
    return r;
}

// Point `index` of the (0, 2)-sequence (van der Corput, Sobol' 2) with a random digital shift
// (XOR of the 32 bits by scramble_x / scramble_y: Kollig & Keller 2002, sec. 2.2). Every prefix of
// 2^m points stays stratified; each point is uniform on [0, 1)^2 for random scrambles. Only the
// top 24 bits are kept, so the float is exact and < 1.
vec2 sobol_2d(uint index, uint scramble_x, uint scramble_y) {
    uint bits = index;
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    uint x = bits ^ scramble_x;
    uint y = sobol2_bits(index) ^ scramble_y;
    return vec2(float(x >> 8u), float(y >> 8u)) * 5.9604644775390625e-08;  // 2^-24
}

// Sample `index` of the 2D dimension pair `dim` at pixel (px, py) for `seed`: pair k uses the
// scrambles of dimensions 2k and 2k + 1. Deterministic for a seed.
vec2 mc_sample_2d(uint px, uint py, uint index, uint seed, uint dim) {
    return sobol_2d(index, mc_scramble(px, py, seed, 2u * dim), mc_scramble(px, py, seed, 2u * dim + 1u));
}

// ---- hemisphere sampling (tangent space) ---------------------------------------------------------

// Uniform direction on the hemisphere z >= 0 (pbrt-v4 SampleUniformHemisphere); pdf 1 / (2 pi).
vec3 sample_uniform_hemisphere(vec2 u) {
    float z = u.x;
    float r = sqrt(max(1.0 - z * z, 0.0));
    float phi = TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Cosine-weighted direction on the hemisphere z >= 0 (Malley's method, polar mapping):
// pdf cos(theta) / pi.
vec3 sample_cosine_hemisphere(vec2 u) {
    float r = sqrt(u.x);
    float phi = TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// pdf of sample_cosine_hemisphere in solid angle.
float pdf_cosine_hemisphere(float NoL) {
    return max(NoL, 0.0) * INV_PI;
}

// Heitz 2018, "Understanding the Masking-Shadowing Function", eq. 34 (Smith G1 for GGX) written as
// 2 NoV / (NoV + sqrt(a^2 + (1 - a^2) NoV^2)).
float g1_smith_ggx(float NoV, float a) {
    NoV = saturate(NoV);
    float a2 = sq(saturate(a));
    return 2.0 * NoV / max(NoV + sqrt(a2 + (1.0 - a2) * NoV * NoV), BRDF_MIN_DENOM);
}

// Dupuy & Benyoub 2023, "Sampling Visible GGX Normals with Spherical Caps", listing 3 (isotropic):
// a half vector h distributed as the visible normals D_v(h) = G1(v) max(v.h, 0) D(h) / (n.v) for
// the view direction v (unit, z >= 0). Heitz 2018 (JCGT 7(4)) gives the same distribution.
// alpha is floored at 1e-4 so roughness 0 still returns a unit vector.
vec3 sample_ggx_vndf(vec2 u, vec3 v, float a) {
    a = max(saturate(a), 1e-4);
    vec3 vh = normalize(vec3(a * v.x, a * v.y, max(v.z, 0.0) + 1e-7));
    float phi = TWO_PI * u.x;
    // the cap's z as e = 1 + z and hh.z = z + vh.z = e - d, d = 1 - vh.z = |vh.xy|^2 / (1 + vh.z):
    // at the cap's rim (u.y -> 1) hh -> 0, where z + vh.z cancelled vh.z's last ulps (normalize's
    // inversesqrt: an H200 and torch were 0.03 apart at v = +Z); 1 - z^2 = e (2 - e)
    float d = dot(vh.xy, vh.xy) / (1.0 + vh.z);
    float e = (1.0 - u.y) * (1.0 + vh.z) + d;
    float sin_theta = sqrt(clamp(e * (2.0 - e), 0.0, 1.0));
    vec3 hh = vec3(sin_theta * cos(phi) + vh.x, sin_theta * sin(phi) + vh.y, e - d);
    vec3 h = vec3(a * hh.x, a * hh.y, max(hh.z, 0.0));
    float len2 = dot(h, h);
    return len2 > 1e-30 ? h * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
}

// pdf (solid angle, of the reflected l = reflect(-v, h)) of sample_ggx_vndf:
// D_v(h) / (4 v.h) = G1(v) D(h) / (4 n.v), written as D(h) / (2 (NoV + sqrt(a^2 + (1 - a^2) NoV^2)))
// so it stays finite at grazing NoV. 0 for half vectors below the surface (NoH <= 0).
float pdf_ggx_vndf(float NoV, float NoH, float a) {
    if (!(NoH > 0.0)) return 0.0;
    NoV = saturate(NoV);
    float a2 = sq(saturate(a));
    float denom = 2.0 * max(NoV + sqrt(a2 + (1.0 - a2) * NoV * NoV), BRDF_MIN_DENOM);
    return d_ggx(NoH, a) / denom;
}

// ---- the BRDF and multiple importance sampling ---------------------------------------------------

// Cook-Torrance specular (Walter et al. 2007): D_GGX V_SmithCorrelated F_Schlick, without n.l.
vec3 ggx_specular_brdf(vec3 f0, float f90, float NoV, float NoL, float NoH, float VoH, float a) {
    return d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a) * f_schlick(f0, f90, VoH);
}

// Probability of sampling the specular lobe in "brdf" sampling: its share of the lobes' albedos
// estimated from Fresnel at n.v (luminance weights). 1 without diffuse, 0 without specular.
float specular_lobe_probability(vec3 diffuse, vec3 f0, float f90, float NoV) {
    const vec3 Y = vec3(0.2126, 0.7152, 0.0722);
    float s = dot(f_schlick(f0, f90, NoV), Y);
    float d = dot(diffuse, Y);
    return s + d > 0.0 ? s / (s + d) : 0.5;
}

// Veach 1997, "Robust Monte Carlo Methods for Light Transport Simulation", eq. 9.13: the weight of
// a sample drawn with pdf_a when pdf_b could also have drawn it; power 2 is the power heuristic
// (beta = 2), anything else the balance heuristic (beta = 1). 0 when both pdfs are 0.
float mis_weight(float pdf_a, float pdf_b, float power) {
    float a = max(pdf_a, 0.0);
    float b = max(pdf_b, 0.0);
    if (power > 1.5) {
        a *= a;
        b *= b;
    }
    return a + b > 0.0 ? a / (a + b) : 0.0;
}

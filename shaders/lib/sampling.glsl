// sampling.glsl - low-discrepancy sequences and GGX importance sampling. No uniforms, no main.
#include "lib/common.glsl"
#include "lib/brdf.glsl"

// Van der Corput 1935 radical inverse in base 2 (bit reversal; Hacker's Delight 7-1 / Dammertz).
// Only the top 24 reversed bits are kept, so the float conversion is exact and the result is
// in [0, 1 - 2^-24]: never 1.0, and bit-identical in any float32 implementation.
float radical_inverse_vdc(uint bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return float(bits >> 8u) * 5.9604644775390625e-08;  // 2^-24
}

// Hammersley 1964 point set: point i of n in [0, 1)^2 = (i / n, radical_inverse(i)); n = 0 acts as 1.
vec2 hammersley(uint i, uint n) {
    return vec2(float(i) / float(max(n, 1u)), radical_inverse_vdc(i));
}

// Walter et al. 2007, eq. 35-36: GGX half vector in tangent space (z = normal) with pdf
// D(h) (n.h); xi in [0, 1)^2, a = alpha in [0, 1]. Returns a unit vector with z >= 0.
vec3 importance_sample_ggx(vec2 xi, float a) {
    float a2 = sq(clamp(a, 0.0, 1.0));
    float phi = TWO_PI * xi.x;
    float t = clamp(xi.y, 0.0, 1.0);
    // cos^2 = (1 - t) / (1 + (a^2 - 1) t), with the denominator written as (1 - t) + a^2 t (a sum
    // of non-negative terms) and sin^2 from its own formula: no cancellation at either end.
    float one_minus_t = 1.0 - t;
    float a2t = a2 * t;
    float denom = max(one_minus_t + a2t, 1e-30);
    float cos2 = clamp(one_minus_t / denom, 0.0, 1.0);
    float sin2 = clamp(a2t / denom, 0.0, 1.0);
    float sin_theta = sqrt(sin2);
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), sqrt(cos2));
}

// Duff et al. 2017, "Building an Orthonormal Basis, Revisited" (JCGT 6(1)), listing 3: rotate a
// tangent-space vector v (z = normal) into the frame of the unit normal n.
vec3 tangent_to_world(vec3 v, vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    vec3 bt = vec3(b, s + n.y * n.y * a, -n.y);
    return t * v.x + bt * v.y + n * v.z;
}

// D(h) of the half vector importance_sample_ggx(xi, a) returns, from xi alone: with
// t = xi.y and q = (1 - t) + a^2 t, cos^2 = (1 - t) / q and sin^2 = a^2 t / q, so the GGX bracket
// cos^2 (a^2 - 1) + 1 = cos^2 a^2 + sin^2 = a^2 / q and D = q^2 / (pi a^2). Equal to
// d_ggx(h.z, a), but well conditioned: for a sharp lobe (a^2 = 1.5e-5) d_ggx(dot(n, h), a) reads
// 1 - n.h ~ 1e-5 off a dot product whose last-ulp rounding (6e-8, and FMA contraction differs
// between drivers) moves D by ~1%. a^2 is floored at BRDF_MIN_A2 as in d_ggx.
float ggx_sample_d(vec2 xi, float a) {
    float a2 = max(sq(clamp(a, 0.0, 1.0)), BRDF_MIN_A2);
    float t = clamp(xi.y, 0.0, 1.0);
    float q = (1.0 - t) + a2 * t;
    return q * q / (PI * a2);
}

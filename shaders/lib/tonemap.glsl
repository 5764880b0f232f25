// tonemap.glsl - exposure, tone mapping operators and the sRGB transfer functions.
#include "lib/common.glsl"

// Exposure in EV stops: radiance * 2^ev.
vec3 apply_exposure(vec3 c, float ev) {
    return c * exp2(ev);
}

// Stephen Hill's fit of the ACES RRT+ODT (BakingLab, 2016), sRGB/Rec.709 primaries in and out.
vec3 rrt_odt_fit(vec3 v) {
    vec3 a = v * (v + 0.0245786) - 0.000090537;
    vec3 b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return a / b;
}

vec3 tonemap_aces_fitted(vec3 c) {
    const mat3 aces_input = mat3(0.59719, 0.07600, 0.02840,
                                 0.35458, 0.90834, 0.13383,
                                 0.04823, 0.01566, 0.83777);
    const mat3 aces_output = mat3(1.60475, -0.10208, -0.00327,
                                  -0.53108, 1.10813, -0.07276,
                                  -0.07367, -0.00605, 1.07602);
    // the fit saturates to 1 well below 1e4; clamping keeps v*v finite in float32
    vec3 v = aces_input * clamp(c, 0.0, 1e4);
    return clamp(aces_output * rrt_odt_fit(v), 0.0, 1.0);
}

// Reinhard et al. 2002, per channel.
vec3 tonemap_reinhard(vec3 c) {
    vec3 x = max(c, vec3(0.0));
    return x / (1.0 + x);
}

// Khronos PBR Neutral (KhronosGroup/ToneMapping, PBR_Neutral/README.md): linear Rec. 709 in,
// linear Rec. 709 in [0, 1] out. Below the compression start K_s = 0.8 - F90 it only subtracts
// the offset f (at most F90 = 0.04, the Fresnel floor of IoR 1.5), so a base colour keeps its
// hue and saturation; above K_s the peak channel is compressed towards 1 and the colour mixed
// towards [p_n, p_n, p_n] at speed K_d = 0.15. Inputs are clamped to [0, 1e6] (the spec asks for
// non-negative input; above 1e6 the output is white within 7e-6).
vec3 tonemap_pbr_neutral(vec3 c) {
    const float f90 = 0.04;
    const float k_s = 0.8 - f90;
    const float k_d = 0.15;
    vec3 x = clamp(c, 0.0, 1e6);
    float m = min(x.r, min(x.g, x.b));
    float f = m <= 2.0 * f90 ? m - m * m / (4.0 * f90) : f90;
    x -= f;
    float p = max(x.r, max(x.g, x.b));
    if (p <= k_s) return x;
    float d = 1.0 - k_s;
    float p_n = 1.0 - d * d / (p + d - k_s);
    float g = 1.0 / (k_d * (p - p_n) + 1.0);
    return x * (p_n / p) * g + vec3(p_n) * (1.0 - g);
}

// AgX's sigmoid on log-encoded values in [0, 1]: Wrensch's 6th-order polynomial fit of Troy
// Sobotka's default contrast curve ("Minimal AgX implementation", iolite-engine.com, 2023; mean
// squared error 3.7e-6), as three.js uses it.
vec3 agx_contrast(vec3 x) {
    vec3 x2 = x * x;
    vec3 x4 = x2 * x2;
    return 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2
        + 0.1191 * x - 0.00232;
}

// AgX as three.js r162+ implements it (src/renderers/shaders/ShaderChunk/
// tonemapping_pars_fragment.glsl.js, AgXToneMapping; Blender 4's AgX base in a Rec. 2020 working
// space): linear Rec. 709 -> Rec. 2020 -> inset matrix -> log2 encoding over [-12.47, 4.03] EV
// -> sigmoid -> outset matrix -> 2.2 power -> Rec. 709. The inset (composed with the Rec. 709 ->
// 2020 matrix) and the outset (the inverse of three.js's AgXOutsetMatrixInv) are precomputed.
// Returns linear Rec. 709 (may leave [0, 1] slightly: clamped here).
vec3 tonemap_agx(vec3 c) {
    const mat3 srgb_to_inset = mat3(0.5448236568, 0.1404419197, 0.0888390519,
                                    0.3737703275, 0.7541441857, 0.1788978601,
                                    0.0813596693, 0.1054103915, 0.7323274369);
    const mat3 outset = mat3(1.1271005818, -0.1413297635, -0.1413297635,
                             -0.1106066431, 1.1578237022, -0.1106066431,
                             -0.0164939387, -0.0164939387, 1.2519364066);
    const mat3 rec2020_to_srgb = mat3(1.6605, -0.1246, -0.0182,
                                      -0.5876, 1.1329, -0.1006,
                                      -0.0728, -0.0083, 1.1187);
    const float min_ev = -12.47393;
    const float max_ev = 4.026069;
    vec3 v = srgb_to_inset * clamp(c, 0.0, 1e6);
    v = (log2(max(v, vec3(1e-10))) - min_ev) / (max_ev - min_ev);
    v = agx_contrast(clamp(v, 0.0, 1.0));
    v = pow(max(outset * v, vec3(0.0)), vec3(2.2));
    return clamp(rec2020_to_srgb * v, 0.0, 1.0);
}

// IEC 61966-2-1 sRGB encoding of linear values in [0, 1].
vec3 linear_to_srgb(vec3 c) {
    vec3 x = clamp(c, 0.0, 1.0);
    vec3 lo = 12.92 * x;
    vec3 hi = 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, lessThanEqual(x, vec3(0.0031308)));
}

vec3 srgb_to_linear(vec3 c) {
    vec3 x = clamp(c, 0.0, 1.0);
    vec3 lo = x / 12.92;
    vec3 hi = pow((x + 0.055) / 1.055, vec3(2.4));
    return mix(hi, lo, lessThanEqual(x, vec3(0.04045)));
}

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

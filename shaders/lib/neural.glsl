// neural.glsl - building blocks of the generated neural-shader GLSL (viewer/neural.py writes
// "generated/neural_student.glsl" / "generated/neural_teacher.glsl" from exported weights, which
// call these). Pure functions, no uniforms. Twins: learned/twins/neural.py.
#include "lib/common.glsl"

// Mildenhall et al. 2020 (NeRF), eq. 4: one Fourier pair (sin(freq x), cos(freq x)) of the
// positional encoding; freq = pi 2^k.
vec2 fourier_feature(float x, float freq) {
    float a = freq * x;
    return vec2(sin(a), cos(a));
}

vec4 relu4(vec4 x) {
    return max(x, vec4(0.0));
}

// Logistic sigmoid 1 / (1 + e^-x), componentwise.
vec4 sigmoid4(vec4 x) {
    return 1.0 / (1.0 + exp(-x));
}

// softplus log(1 + e^x) written as max(x, 0) + log(1 + e^-|x|) so large |x| cannot overflow.
vec4 softplus4(vec4 x) {
    // log(1 + y) with y = e^-|x| in (0, 1], computed as log(u) * y / (u - 1), u = 1 + y
    // (Goldberg 1991): plain log(1 + y) loses all digits of y below 1e-4 (rel. error 1.5e-4
    // measured at x = -6 on llvmpipe); where u rounds to 1, log1p(y) = y.
    vec4 y = exp(-abs(x));
    vec4 u = 1.0 + y;
    vec4 d = u - 1.0;
    vec4 l1p = mix(log(u) * y / max(d, vec4(1e-30)), y, equal(d, vec4(0.0)));
    return max(x, vec4(0.0)) + l1p;
}

// The half vector of the PBND specular network input (thesis fig. 4.5): normalize(v + l), with the
// fallback v when v + l vanishes (l = -v).
vec3 neural_half_vector(vec3 v, vec3 l) {
    vec3 h = v + l;
    float len2 = dot(h, h);
    return len2 > 1e-12 ? h * inversesqrt(len2) : v;
}

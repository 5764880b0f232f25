// path.glsl - the small pure pieces of the path tracer (passes/shade_path.frag): sampling a
// distant disc light's cone and the Russian roulette's survival probability. No uniforms, no main.
// Twins: learned/twins/path.py.
#include "lib/common.glsl"

// A direction uniformly distributed over the cone of half-angle acos(cos_max) about +Z (PBRT 4,
// sec. A.5.4), from u in [0, 1)^2; its pdf in solid angle is pdf_uniform_cone(cos_max).
vec3 sample_uniform_cone(vec2 u, float cos_max) {
    float cos_t = 1.0 - u.x * (1.0 - cos_max);
    float sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    float phi = TWO_PI * u.y;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

// 1 / (the cone's solid angle 2 pi (1 - cos_max)); a degenerate cone (cos_max >= 1) gives 0.
float pdf_uniform_cone(float cos_max) {
    float omega = TWO_PI * (1.0 - cos_max);
    return omega > 0.0 ? 1.0 / omega : 0.0;
}

// The probability that a path of throughput beta goes on after `bounce` bounces: 1 for the
// first three (the reference's depth is reached unbiasedly either way), then the throughput's
// largest component, at most 0.95 and at least 0.05 (Russian roulette: a path that survives
// divides its throughput by this, so the estimate stays unbiased).
float path_continue_probability(vec3 beta, float bounce) {
    if (bounce < 3.0) return 1.0;
    return clamp(max(beta.r, max(beta.g, beta.b)), 0.05, 0.95);
}

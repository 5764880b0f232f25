// parity_env_sampling.comp - lib/env_sampling.glsl's sample_env and env_pdf on a list of inputs,
// for the parity check against learned.twins.env_sampling (learned/parity/checks/env_sampling.py).
#include "lib/env_sampling.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_env_marginal;
uniform sampler2D u_env_conditional;
uniform sampler2D u_env_pdf;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [n][5] u, dir
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [n][5] sample, pdf(dir)
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec4 s = sample_env(u_env_marginal, u_env_conditional, u_env_pdf,
                        vec2(inv[5u * i], inv[5u * i + 1u]));
    float p = env_pdf(u_env_pdf, vec3(inv[5u * i + 2u], inv[5u * i + 3u], inv[5u * i + 4u]));
    outv[5u * i] = s.x; outv[5u * i + 1u] = s.y; outv[5u * i + 2u] = s.z;
    outv[5u * i + 3u] = s.w; outv[5u * i + 4u] = p;
}

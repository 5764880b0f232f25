// env_cdf_pdf.comp - step 3: the density on the uv square of every texel, p_uv = f / mean(f)
// (f from env_cdf_rows.comp, mean over all W x H texels); in the fallback, H sin(theta_r) / sum_r
// sin(theta_r).
// Its mean over the texels is 1, so it integrates to one over [0, 1]^2.
// Twin: learned.twins.env_sampling.env_distribution.
#include "lib/env_sampling.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = 0) uniform image2D u_func;                      // in: f, out: p_uv
layout(std430, binding = 3) readonly buffer Stats { float stats[]; };  // total, fallback

void main() {
    ivec2 size = imageSize(u_func);
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    bool fallback = stats[1] > 0.5;
    float total = stats[0];
    // fallback: total sums the row weights, each row's texels share its weight equally
    float p_uv = fallback ? env_row_sin_theta(p.y, size.y) * float(size.y) / total
                          : imageLoad(u_func, p).r * (float(size.x) * float(size.y) / total);
    imageStore(u_func, p, vec4(p_uv));
}

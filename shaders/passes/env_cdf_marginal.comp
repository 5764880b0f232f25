// env_cdf_marginal.comp - step 2 (one invocation): the marginal CDF over rows from the row sums of
// env_cdf_rows.comp. If every row is 0 (a black environment) or the total overflows, the
// distribution falls back to uniform on the sphere (row weights sin(theta_r), uniform columns) and
// Stats.fallback = 1. Twin: learned.twins.env_sampling.env_distribution.
#include "lib/env_sampling.glsl"

layout(local_size_x = 1) in;
layout(r32f, binding = 0) writeonly uniform image2D u_marginal;      // [(H + 1) x 1]
layout(std430, binding = 2) readonly buffer Rows { float row_sum[]; };  // [H]
layout(std430, binding = 3) writeonly buffer Stats { float stats[]; };  // total, fallback
uniform int u_height;

void main() {
    int h = u_height;
    float total = 0.0;
    for (int r = 0; r < h; ++r) {
        total += row_sum[r];
    }
    bool fallback = !(total > 0.0 && total < 3.0e38);
    if (fallback) {
        total = 0.0;
        for (int r = 0; r < h; ++r) {
            total += env_row_sin_theta(r, h);
        }
    }
    float acc = 0.0;
    imageStore(u_marginal, ivec2(0, 0), vec4(0.0));
    for (int r = 0; r < h; ++r) {
        acc += fallback ? env_row_sin_theta(r, h) : row_sum[r];
        imageStore(u_marginal, ivec2(r + 1, 0), vec4(r + 1 == h ? 1.0 : min(acc / total, 1.0)));
    }
    stats[0] = total;
    stats[1] = fallback ? 1.0 : 0.0;
}

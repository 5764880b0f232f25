// env_cdf_rows.comp - step 1 of the environment sampling distribution (viewer/environment/sampling.py):
// one invocation per equirect row. The unnormalised density of texel (c, r) is
//   f(c, r) = max of the luminance over the 3x3 texels around (c, r) (u wraps, v clamps) x sin(theta_r)
// (the dilation keeps f > 0 wherever the bilinear radiance lookup is > 0, so sampling only the
// environment stays unbiased). Writes f to u_func, the row's normalised CDF over columns to
// u_conditional (uniform for a row whose f sums to 0 or overflows) and the row sum to Rows.
// Twin: learned.twins.env_sampling.env_distribution.
#include "lib/env_sampling.glsl"

layout(local_size_x = 64) in;
uniform sampler2D u_env_radiance;                                    // level 0, [W x H] RGBA32F
layout(r32f, binding = 0) writeonly uniform image2D u_func;          // [W x H]
layout(r32f, binding = 1) writeonly uniform image2D u_conditional;   // [(W + 1) x H]
layout(std430, binding = 2) writeonly buffer Rows { float row_sum[]; };  // [H]

float dilated_luminance(ivec2 p, ivec2 size) {
    float m = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        int y = clamp(p.y + dy, 0, size.y - 1);
        for (int dx = -1; dx <= 1; ++dx) {
            int x = (p.x + dx + size.x) % size.x;
            m = max(m, luminance(texelFetch(u_env_radiance, ivec2(x, y), 0).rgb));
        }
    }
    return m;
}

void main() {
    ivec2 size = textureSize(u_env_radiance, 0);
    int row = int(gl_GlobalInvocationID.x);
    if (row >= size.y) return;
    float s = env_row_sin_theta(row, size.y);
    float total = 0.0;
    for (int c = 0; c < size.x; ++c) {
        float f = dilated_luminance(ivec2(c, row), size) * s;
        imageStore(u_func, ivec2(c, row), vec4(f));
        total += f;
    }
    bool usable = total > 0.0 && total < 3.0e38;
    float acc = 0.0;
    imageStore(u_conditional, ivec2(0, row), vec4(0.0));
    for (int c = 0; c < size.x; ++c) {
        acc += dilated_luminance(ivec2(c, row), size) * s;
        float cdf = usable ? acc / total : float(c + 1) / float(size.x);
        imageStore(u_conditional, ivec2(c + 1, row), vec4(c + 1 == size.x ? 1.0 : min(cdf, 1.0)));
    }
    row_sum[row] = usable ? total : 0.0;
}

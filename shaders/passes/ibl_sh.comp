// ibl_sh.comp - partial sums of the radiance SH projection L_lm = sum L(w) Y_lm(w) dw over a run of
// up to 64 texels of one row (Ramamoorthi & Hanrahan 2001 eq. 10 as a quadrature over texels). The
// texel solid angle is exact for an equirect row: (2 pi / W)(cos theta0 - cos theta1), written as
// (2 pi / W) 2 sin(theta_c) sin(pi / 2H) to avoid cancellation. viewer/environment/ibl.py sums the runs in
// float64. Each invocation sums its run in registers, in order: no shared memory and no barriers
// (the 8x8-tile tree reduction before took 1.3 s for a 2048x1024 map on llvmpipe, this 0.05 s).
// Twin: learned.twins.ibl_precompute.sh_project.
#include "lib/common.glsl"
#include "lib/equirect.glsl"
#include "lib/sh.glsl"

#define SH_RUN 64
layout(local_size_x = 64) in;
layout(rgba32f, binding = 0) readonly uniform image2D u_env;     // level 0 radiance
layout(std430, binding = 1) writeonly buffer Partial { float partial[]; };  // [runs][9][3]

void main() {
    ivec2 size = imageSize(u_env);
    int runs = (size.x + SH_RUN - 1) / SH_RUN;
    int id = int(gl_GlobalInvocationID.x);
    if (id >= runs * size.y) return;
    int y = id / runs;
    int x0 = (id - y * runs) * SH_RUN;
    int x1 = min(x0 + SH_RUN, size.x);
    float v = (float(y) + 0.5) / float(size.y);
    float d_omega = (TWO_PI / float(size.x)) * 2.0 * sin(PI * v) * sin(0.5 * PI / float(size.y));
    vec3 acc[9];
    for (int c = 0; c < 9; ++c) acc[c] = vec3(0.0);
    for (int x = x0; x < x1; ++x) {
        vec2 uv = vec2((float(x) + 0.5) / float(size.x), v);
        vec3 n = equirect_dir(uv);
        vec3 radiance = imageLoad(u_env, ivec2(x, y)).rgb * d_omega;
        for (int c = 0; c < 9; ++c) acc[c] += radiance * sh_basis(c, n);
    }
    for (int c = 0; c < 9; ++c) {
        partial[27 * id + 3 * c + 0] = acc[c].x;
        partial[27 * id + 3 * c + 1] = acc[c].y;
        partial[27 * id + 3 * c + 2] = acc[c].z;
    }
}

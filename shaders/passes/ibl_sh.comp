// ibl_sh.comp - partial sums of the radiance SH projection L_lm = sum L(w) Y_lm(w) dw over the
// texels of one 8x8 tile (Ramamoorthi & Hanrahan 2001 eq. 10 as a quadrature over texels). The
// texel solid angle is exact for an equirect row: (2 pi / W)(cos theta0 - cos theta1), written as
// (2 pi / W) 2 sin(theta_c) sin(pi / 2H) to avoid cancellation. viewer/ibl.py sums the tiles in
// float64. Twin: learned.twins.ibl.sh_project.
#include "lib/common.glsl"
#include "lib/equirect.glsl"
#include "lib/sh.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) readonly uniform image2D u_env;     // level 0 radiance
layout(std430, binding = 1) writeonly buffer Partial { float partial[]; };  // [tiles][9][3]

shared vec3 s_acc[9 * 64];

void main() {
    ivec2 size = imageSize(u_env);
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint lid = gl_LocalInvocationIndex;
    vec3 radiance = vec3(0.0);
    vec3 n = vec3(0.0, 1.0, 0.0);
    if (all(lessThan(p, size))) {
        vec2 uv = (vec2(p) + 0.5) / vec2(size);
        n = equirect_dir(uv);
        float d_omega = (TWO_PI / float(size.x)) * 2.0 * sin(PI * uv.y)
                        * sin(0.5 * PI / float(size.y));
        radiance = imageLoad(u_env, p).rgb * d_omega;
    }
    for (int c = 0; c < 9; ++c) {
        s_acc[c * 64 + int(lid)] = radiance * sh_basis(c, n);
    }
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            for (int c = 0; c < 9; ++c) {
                s_acc[c * 64 + int(lid)] += s_acc[c * 64 + int(lid + stride)];
            }
        }
        barrier();
    }
    if (lid == 0u) {
        uint tile = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
        for (int c = 0; c < 9; ++c) {
            vec3 s = s_acc[c * 64];
            partial[27u * tile + uint(3 * c) + 0u] = s.x;
            partial[27u * tile + uint(3 * c) + 1u] = s.y;
            partial[27u * tile + uint(3 * c) + 2u] = s.z;
        }
    }
}

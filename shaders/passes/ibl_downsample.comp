// ibl_downsample.comp - one level of the box-filtered radiance mip chain: dst(x, y) is the mean of
// src texels (2x..2x+1, 2y..2y+1), indices clamped to src (a 1-texel-high source repeats its row).
// Twin: learned.twins.ibl.downsample_box.
#include "lib/common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) readonly uniform image2D u_src;   // level k - 1
layout(rgba32f, binding = 1) writeonly uniform image2D u_dst;  // level k

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(u_dst)))) return;
    ivec2 last = imageSize(u_src) - 1;
    ivec2 s0 = min(2 * p, last);
    ivec2 s1 = min(2 * p + 1, last);
    vec4 c = ((imageLoad(u_src, s0) + imageLoad(u_src, ivec2(s1.x, s0.y)))
              + (imageLoad(u_src, ivec2(s0.x, s1.y)) + imageLoad(u_src, s1))) * 0.25;
    imageStore(u_dst, p, c);
}

// ibl_downsample.comp - one level of the radiance mip chain: dst(x, y) is the solid-angle-weighted
// mean of src texels (2x..2x+1, 2y..2y+1), indices clamped to src (a 1-texel-high source repeats
// its row). An equirect texel's solid angle is proportional to sin(theta) of its row centre
// (theta = pi (y + 0.5) / h), so the two source rows are weighted by their sin(theta): the coarse
// texel then holds the mean radiance over the solid angle it covers and every level keeps the
// environment's energy. A plain 2x2 box does not: it over-weights the rows nearer the pole, and a
// sun 7 degrees from the zenith (assets/environments/esplanade.exr) grew to 1.8x its energy at the
// 8x4 level the GGX prefilter reads for rough lobes (README "Split-sum accuracy").
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
    float inv_h = 1.0 / float(last.y + 1);
    float w0 = sin(PI * (float(s0.y) + 0.5) * inv_h);
    float w1 = sin(PI * (float(s1.y) + 0.5) * inv_h);
    vec4 top = imageLoad(u_src, s0) + imageLoad(u_src, ivec2(s1.x, s0.y));
    vec4 bottom = imageLoad(u_src, ivec2(s0.x, s1.y)) + imageLoad(u_src, s1);
    vec4 c = (top * w0 + bottom * w1) * (0.5 / (w0 + w1));
    imageStore(u_dst, p, c);
}

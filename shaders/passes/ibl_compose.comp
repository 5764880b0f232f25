// ibl_compose.comp - one level k >= 1 of a prefiltered chain from the CPU convolution
// (viewer/environment/prefilter.py, IBLOptions.prefilter_method = "convolution"): the level computed at the
// working width (u_work, GL_LINEAR, REPEAT u, CLAMP v) read at this level's texel centres (an
// exact copy where the sizes match, a bilinear upsampling, continuous across the poles, where the
// level was computed at a lower resolution: maps wider than the working width),
// plus the environment's sun as points (viewer.environment.prefilter.sun_points) convolved with the level's
// GGX kernel k(n.l) = D(h) max(n.l, 0), h = normalize(n + l), at this texel's full resolution:
// the sun-less chain takes 0 points, the whole environment's chain the sun's. Each point's energy
// is already divided by the kernel's integral Z(alpha), so this is the CPU sum's normalisation.
// Twin: learned.twins.ibl_precompute.compose_level.
#include "lib/common.glsl"
#include "lib/equirect.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) writeonly uniform image2D u_dst;  // level k of the chain
// [2 i]: direction, [2 i + 1]: energy / Z; a uniform block (an SSBO read in the loop was 12x
// slower on llvmpipe), at most 256 points (viewer.environment.prefilter.SUN_MAX_POINTS)
layout(std140, binding = 1) uniform Points { vec4 points[512]; };
uniform sampler2D u_work;  // level k at the working width
uniform int u_points;      // how many sun points (0: the sun-less chain)
uniform float u_a2;        // alpha^2 of this level (viewer.environment.ibl.prefilter_roughness^4)

// k(n.l) / (a^2 / pi) for unit n, l: with u = 1 - n.l = |n - l|^2 / 2 (no cancellation where the
// sharp kernels live, n ~ l), n.h^2 = 1 - u / 2 and the GGX bracket n.h^2 (a^2 - 1) + 1 =
// a^2 + u (1 - a^2) / 2; zero below the horizon (u >= 1).
float compose_kernel(vec3 n, vec3 l, float a2) {
    vec3 d = n - l;
    float u = 0.5 * dot(d, d);
    float bracket = a2 + u * (0.5 * (1.0 - a2));
    return max(1.0 - u, 0.0) / (bracket * bracket);
}

// The working level at uv, bilinear, continuous across the poles: between the first (last) row's
// centre and the pole, the row is interpolated with itself half a turn round (the texel the great
// circle through the pole reaches next), where CLAMP_TO_EDGE would hold the row's value to the pole
// (a 16x8 level upsampled to 64x32 erred by 10 % in its last row).
vec3 compose_sample(sampler2D work, vec2 uv) {
    float h = float(textureSize(work, 0).y);
    float y = uv.y * h - 0.5;
    if (y >= 0.0 && y <= h - 1.0) return textureLod(work, uv, 0.0).rgb;
    float edge = y < 0.0 ? 0.5 / h : 1.0 - 0.5 / h;  // the first (last) row's centre
    float t = y < 0.0 ? -y : y - (h - 1.0);           // in [0, 0.5]: rows past it
    vec3 here = textureLod(work, vec2(uv.x, edge), 0.0).rgb;
    vec3 across = textureLod(work, vec2(uv.x + 0.5, edge), 0.0).rgb;
    return mix(here, across, t);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_dst);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec3 c = compose_sample(u_work, uv);
    if (u_points > 0) {
        vec3 n = equirect_dir(uv);
        vec3 sun = vec3(0.0);
        for (int i = 0; i < u_points; ++i) {
            sun += points[2 * i + 1].rgb * compose_kernel(n, points[2 * i].xyz, u_a2);
        }
        c += sun * (u_a2 * INV_PI);
    }
    imageStore(u_dst, p, vec4(c, 1.0));
}

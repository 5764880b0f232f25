// ibl_prefilter.comp - one level of the GGX-prefiltered specular chain (split-sum first term,
// Karis 2013, with n = v = r). Filtered importance sampling (Krivanek & Colbert 2008, GPU Gems 3
// ch. 20): each GGX sample reads the radiance chain at the mip whose texel solid angle matches the
// sample's solid angle, lod = 0.5 log2(omega_s / omega_p), without the paper's +1 bias: that extra
// mip of blur widens the lobe around a small sun (the procedural sky's 2-degree sun at r = 0.3:
// 12.7 % median per-pixel error against the path tracer with 256 samples and the +1, 5.1 % with
// 1024 samples and no bias, 3.8 % with an exact prefilter; README "Split-sum accuracy"). Weights
// are n.l, normalised by their sum, so a constant environment stays constant.
// Twin: learned.twins.ibl.prefilter_environment.
#include "lib/common.glsl"
#include "lib/brdf.glsl"
#include "lib/sampling.glsl"
#include "lib/equirect.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) writeonly uniform image2D u_dst;
uniform sampler2D u_radiance;  // box-filtered radiance chain (REPEAT u, CLAMP v, trilinear)
uniform float u_roughness;     // perceptual roughness of this level (viewer.environment.ibl.prefilter_roughness)
uniform uint u_samples;        // Hammersley points per texel
uniform float u_omega_p;       // mean solid angle of a level-0 radiance texel, 4 pi / (W H)
uniform float u_max_lod;       // last level of the radiance chain

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(u_dst);
    if (any(greaterThanEqual(p, size))) return;
    vec3 n = equirect_dir((vec2(p) + 0.5) / vec2(size));
    float a = u_roughness * u_roughness;
    float inv_samples = 1.0 / float(u_samples);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (uint i = 0u; i < u_samples; ++i) {
        vec2 xi = hammersley(i, u_samples);
        vec3 h = tangent_to_world(importance_sample_ggx(xi, a), n);
        float NoH = dot(n, h);  // = v.h, since v = n
        vec3 l = 2.0 * NoH * h - n;
        float NoL = dot(n, l);
        if (NoL > 0.0) {
            // pdf(l) = D(h) (n.h) / (4 v.h) = D / 4 with v = n; D from xi (ggx_sample_d), not
            // from NoH: 1 - NoH of a sharp lobe is ~1e-5 and an ulp of the dot product moves it 1%
            float pdf = ggx_sample_d(xi, a) * 0.25;
            float omega_s = inv_samples / max(pdf, 1e-30);
            float lod = clamp(0.5 * log2(omega_s / u_omega_p), 0.0, u_max_lod);
            sum += textureLod(u_radiance, equirect_uv(l), lod).rgb * NoL;
            weight += NoL;
        }
    }
    imageStore(u_dst, p, vec4(sum / max(weight, 1e-30), 1.0));
}

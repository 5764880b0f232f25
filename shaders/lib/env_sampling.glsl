// env_sampling.glsl - importance sampling of an equirect environment from a piecewise-constant 2D
// distribution (Pharr, Jakob & Humphreys, PBR 3rd ed. sec. 13.6.7 and 14.2.4): the density on the
// uv square is proportional to luminance x sin(theta), sampled with a marginal CDF over rows and
// one conditional CDF per row. Textures (R32F, NEAREST, texelFetch only), built by
// viewer/environment/sampling.py (passes/env_cdf_*.comp):
//   marginal    [(H + 1) x 1]  cdf over rows, texel 0 = 0, texel H = 1
//   conditional [(W + 1) x H]  per row: cdf over columns, texel 0 = 0, texel W = 1
//   pdf         [W x H]        p_uv of each texel (density on [0, 1]^2, mean 1)
// Directions are in the environment's own frame (apply env_dir / rotate_y outside). No uniforms.
// Twins: learned/twins/env_sampling.py.
#include "lib/common.glsl"
#include "lib/equirect.glsl"

// ITU-R BT.709 relative luminance of linear RGB.
float luminance(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

// pdf in solid angle of a direction drawn uniformly in uv with density pdf_uv on the equirect
// square: dw = 2 pi^2 sin(theta) du dv (PBR 3rd ed. eq. 14.8). 0 at the poles (sin theta = 0).
float env_pdf_solid_angle(float pdf_uv, float sin_theta) {
    return sin_theta > 0.0 ? pdf_uv / (2.0 * PI * PI * sin_theta) : 0.0;
}

// Largest i in [0, n - 1] with cdf[i] <= u, for a non-decreasing cdf in texels 0..n of `row`
// (cdf[0] = 0, cdf[n] = 1, u in [0, 1)): the interval [cdf[i], cdf[i + 1]) holding u, never a
// zero-width one.
int cdf_find(sampler2D cdf, int row, int n, float u) {
    int lo = 0;
    int hi = n;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (texelFetch(cdf, ivec2(mid, row), 0).r <= u) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Draw a direction from the environment distribution with the uniform pair u in [0, 1)^2:
// returns (direction in the environment frame, pdf in solid angle). pdf 0 marks a sample to skip
// (a pole, where the solid-angle density is undefined).
vec4 sample_env(sampler2D marginal, sampler2D conditional, sampler2D pdf_uv, vec2 u) {
    ivec2 size = textureSize(pdf_uv, 0);  // (W, H)
    int row = cdf_find(marginal, 0, size.y, u.y);
    float m0 = texelFetch(marginal, ivec2(row, 0), 0).r;
    float m1 = texelFetch(marginal, ivec2(row + 1, 0), 0).r;
    float dv = clamp((u.y - m0) / max(m1 - m0, 1e-30), 0.0, 1.0);
    int col = cdf_find(conditional, row, size.x, u.x);
    float c0 = texelFetch(conditional, ivec2(col, row), 0).r;
    float c1 = texelFetch(conditional, ivec2(col + 1, row), 0).r;
    float du = clamp((u.x - c0) / max(c1 - c0, 1e-30), 0.0, 1.0);
    vec2 uv = vec2((float(col) + du) / float(size.x), (float(row) + dv) / float(size.y));
    vec3 d = equirect_dir(uv);
    float p = env_pdf_solid_angle(texelFetch(pdf_uv, ivec2(col, row), 0).r, sin(PI * uv.y));
    return vec4(d, p);
}

// pdf in solid angle with which sample_env draws the unit direction d (environment frame).
float env_pdf(sampler2D pdf_uv, vec3 d) {
    ivec2 size = textureSize(pdf_uv, 0);
    vec2 uv = equirect_uv(d);
    ivec2 texel = clamp(ivec2(floor(uv * vec2(size))), ivec2(0), size - 1);
    return env_pdf_solid_angle(texelFetch(pdf_uv, texel, 0).r, length(d.xz));
}

// sin(theta) at the centre of equirect row `row` of `height`: the row's solid-angle weight.
float env_row_sin_theta(int row, int height) {
    return sin(PI * (float(row) + 0.5) / float(max(height, 1)));
}

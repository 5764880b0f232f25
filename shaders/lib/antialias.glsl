// antialias.glsl - anti-aliasing of the display image: FXAA 3.11 (quality preset 12) and the box
// resolve of a supersampled radiance target. No uniforms, no main. Positions are in pixels of
// the texture (pixel i's centre at i + 0.5), GL row order.
// Twins: learned/twins/antialias.py (same names).
#include "lib/tonemap.glsl"

// Luma of an sRGB-encoded colour: Rec. 601 weights, what FXAA 3.11's notes suggest computing
// into alpha before the pass (here computed per texel instead).
float fxaa_luma(vec3 rgb) {
    return dot(rgb, vec3(0.299, 0.587, 0.114));
}

// A display texel as FXAA filters it: linear RGB and perceptual luma, as an sRGB texture with
// the luma in alpha filters in FXAA's recommended set-up (colour blended in linear light, the
// edge tests on perceptual luma).
vec4 fxaa_texel(vec4 srgb) {
    return vec4(srgb_to_linear(srgb.rgb), fxaa_luma(srgb.rgb));
}

// A bilinear sample of `tex` at `pos` (pixels), clamped to the edge: FXAA's FxaaTexTop and
// FxaaTexOff, filtered in float from four texelFetch (a GPU's fixed-point filtering weights
// would differ from the twin's). `display`: each texel through fxaa_texel first (rgb linear, a
// luma); else the raw texels (the alpha channel).
vec4 fxaa_fetch(sampler2D tex, vec2 pos, bool display) {
    ivec2 hi = textureSize(tex, 0) - 1;
    vec2 p = pos - 0.5;
    vec2 i0 = floor(p);
    vec2 f = p - i0;
    ivec2 a = clamp(ivec2(i0), ivec2(0), hi);
    ivec2 b = clamp(ivec2(i0) + 1, ivec2(0), hi);
    vec4 c00 = texelFetch(tex, a, 0);
    vec4 c10 = texelFetch(tex, ivec2(b.x, a.y), 0);
    vec4 c01 = texelFetch(tex, ivec2(a.x, b.y), 0);
    vec4 c11 = texelFetch(tex, b, 0);
    if (display) {
        c00 = fxaa_texel(c00);
        c10 = fxaa_texel(c10);
        c01 = fxaa_texel(c01);
        c11 = fxaa_texel(c11);
    }
    return mix(mix(c00, c10, f.x), mix(c01, c11, f.x), f.y);
}

float fxaa_luma_at(sampler2D tex, vec2 pos) {
    return fxaa_fetch(tex, pos, true).a;
}

// FXAA 3.11, PC quality (Timothy Lottes, NVIDIA, 2011; FXAA_QUALITY__PRESET 12, the default):
// a pixel whose 4-neighbourhood luma range exceeds max(0.0833, 0.166 * its maximum) is on an
// edge; the edge's direction is taken from the 3x3 second differences, its two ends are
// searched along it (steps 1, 1.5, 2, 4, 12 pixels) until the luma leaves the edge's mean, and
// the pixel is resampled up to half a pixel across the edge in proportion to its distance to
// the nearer end, or by the sub-pixel aliasing estimate (subpix 0.75), whichever is larger.
// `pos`: the pixel's centre. Returns the filtered colour, sRGB-encoded, and the alpha (coverage)
// sampled at the same place.
vec4 fxaa(sampler2D tex, vec2 pos) {
    const float subpix = 0.75;
    const float edge_threshold = 0.166;
    const float edge_threshold_min = 0.0833;
    const float steps[5] = float[5](1.0, 1.5, 2.0, 4.0, 12.0);
    vec4 rgba_m = texelFetch(tex, ivec2(pos), 0);
    float luma_m = fxaa_luma(rgba_m.rgb);
    float luma_s = fxaa_luma_at(tex, pos + vec2(0.0, 1.0));
    float luma_e = fxaa_luma_at(tex, pos + vec2(1.0, 0.0));
    float luma_n = fxaa_luma_at(tex, pos + vec2(0.0, -1.0));
    float luma_w = fxaa_luma_at(tex, pos + vec2(-1.0, 0.0));
    float range_max = max(max(luma_n, luma_w), max(luma_e, max(luma_s, luma_m)));
    float range_min = min(min(luma_n, luma_w), min(luma_e, min(luma_s, luma_m)));
    float range = range_max - range_min;
    if (range < max(edge_threshold_min, range_max * edge_threshold)) return rgba_m;

    float luma_nw = fxaa_luma_at(tex, pos + vec2(-1.0, -1.0));
    float luma_se = fxaa_luma_at(tex, pos + vec2(1.0, 1.0));
    float luma_ne = fxaa_luma_at(tex, pos + vec2(1.0, -1.0));
    float luma_sw = fxaa_luma_at(tex, pos + vec2(-1.0, 1.0));
    float luma_ns = luma_n + luma_s;
    float luma_we = luma_w + luma_e;
    float luma_nese = luma_ne + luma_se;
    float luma_nwsw = luma_nw + luma_sw;
    float edge_horz = abs(-2.0 * luma_w + luma_nwsw) + 2.0 * abs(-2.0 * luma_m + luma_ns)
        + abs(-2.0 * luma_e + luma_nese);
    float edge_vert = abs(-2.0 * luma_s + luma_sw + luma_se) + 2.0 * abs(-2.0 * luma_m + luma_we)
        + abs(-2.0 * luma_n + luma_nw + luma_ne);
    bool horz_span = edge_horz >= edge_vert;
    // sub-pixel aliasing: the 3x3 low-pass against the centre, relative to the range
    float subpix_a = 2.0 * (luma_ns + luma_we) + luma_nwsw + luma_nese;
    float subpix_c = clamp(abs(subpix_a / 12.0 - luma_m) / range, 0.0, 1.0);
    float subpix_f = (-2.0 * subpix_c + 3.0) * subpix_c * subpix_c;

    if (!horz_span) {
        luma_n = luma_w;
        luma_s = luma_e;
    }
    float gradient_n = luma_n - luma_m;
    float gradient_s = luma_s - luma_m;
    bool pair_n = abs(gradient_n) >= abs(gradient_s);
    float gradient = max(abs(gradient_n), abs(gradient_s));
    float length_sign = pair_n ? -1.0 : 1.0;  // towards the neighbour across the edge
    float luma_nn = (pair_n ? luma_n : luma_s) + luma_m;

    // search along the edge, half a pixel across it (the mean of its two sides)
    vec2 across = horz_span ? vec2(0.0, 1.0) : vec2(1.0, 0.0);
    vec2 along = horz_span ? vec2(1.0, 0.0) : vec2(0.0, 1.0);
    vec2 pos_b = pos + across * (0.5 * length_sign);
    vec2 pos_n = pos_b - along * steps[0];
    vec2 pos_p = pos_b + along * steps[0];
    float gradient_scaled = gradient * 0.25;
    bool luma_m_lt_zero = luma_m - luma_nn * 0.5 < 0.0;
    float end_n = fxaa_luma_at(tex, pos_n) - luma_nn * 0.5;
    float end_p = fxaa_luma_at(tex, pos_p) - luma_nn * 0.5;
    bool done_n = abs(end_n) >= gradient_scaled;
    bool done_p = abs(end_p) >= gradient_scaled;
    for (int i = 1; i < 5; ++i) {
        if (!done_n) pos_n -= along * steps[i];
        if (!done_p) pos_p += along * steps[i];
        if (done_n && done_p) break;
        if (i == 4) break;
        if (!done_n) end_n = fxaa_luma_at(tex, pos_n) - luma_nn * 0.5;
        if (!done_p) end_p = fxaa_luma_at(tex, pos_p) - luma_nn * 0.5;
        done_n = abs(end_n) >= gradient_scaled;
        done_p = abs(end_p) >= gradient_scaled;
    }
    float dst_n = dot(pos - pos_n, along);
    float dst_p = dot(pos_p - pos, along);
    bool good_span_n = (end_n < 0.0) != luma_m_lt_zero;
    bool good_span_p = (end_p < 0.0) != luma_m_lt_zero;
    bool good_span = dst_n < dst_p ? good_span_n : good_span_p;
    float pixel_offset = 0.5 - min(dst_n, dst_p) / (dst_n + dst_p);
    float offset = max(good_span ? pixel_offset : 0.0, subpix_f * subpix_f * subpix);
    vec2 at = pos + across * (offset * length_sign);
    return vec4(linear_to_srgb(fxaa_fetch(tex, at, true).rgb), fxaa_fetch(tex, at, false).a);
}

// Box resolve of supersampling: the mean of the n x n texels of `tex` (the radiance rendered at
// n times the size) that output pixel `pixel` covers, in linear radiance.
vec4 ssaa_resolve(sampler2D tex, ivec2 pixel, int n) {
    vec4 sum = vec4(0.0);
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            sum += texelFetch(tex, pixel * n + ivec2(i, j), 0);
        }
    }
    return sum / float(n * n);
}

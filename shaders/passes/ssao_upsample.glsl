// ssao_upsample.glsl - what the SSAO passes at reduced scale share (SSAO_SCALE = k > 1 renders
// one pixel of k x k: render.ssao_scale): which full-resolution pixel a low-resolution texel
// stands for, the joint bilateral upsampling of a low-resolution result to a full-resolution
// pixel (weights: lib/ssao.glsl ssao_upsample_weight), and the bilateral blur of a
// full-resolution result with the same weights (passes/ssao_blur.frag). Pass-level chunk:
// needs passes/deferred.glsl (G-buffer, camera uniforms), lib/shading.glsl and lib/ssao.glsl
// included first.
// Twins: learned/twins/ssao.py (ssao_sample_pixel, ssao_upsample, ssao_blur).
#ifndef SSAO_SCALE
#define SSAO_SCALE 1
#endif

vec3 to_view(vec3 w) {
    return transpose(u_camera_to_world) * w;
}

// The full-resolution pixel that low-resolution texel t marches from: the centre pixel of its
// k x k block (the block's lower-right one of the centre four for even k), clamped to the frame
// when k does not divide its size. k = 1: t itself.
ivec2 ssao_sample_pixel(ivec2 t) {
    return min(t * SSAO_SCALE + SSAO_SCALE / 2, ivec2(u_resolution) - 1);
}

// The low-resolution texture `low` at full-resolution pixel `pixel` (G-buffer g, a surface): the
// four texels whose sample pixels surround it, bilinear weights times ssao_upsample_weight,
// normalised. Where every weight is 0 (a feature no sample pixel saw), the texel whose sample
// lies nearest in depth; where no sample pixel has a surface, `fallback`. A pixel that is itself
// a sample pixel gets its texel's value exactly.
vec4 ssao_upsample(sampler2D low, ivec2 pixel, GBuffer g, vec4 fallback) {
    vec2 frag = vec2(pixel) + 0.5;
    vec3 n = to_view(shading_normal(g.normal, -view_ray_ws(frag)));
    vec3 p = view_position(frag, u_resolution, g.depth, u_tan_half_fov);
    ivec2 size = textureSize(low, 0);
    // texel t's sample pixel centre sits at t k + floor(k / 2) + 0.5
    vec2 c = vec2(pixel - ivec2(SSAO_SCALE / 2)) / float(SSAO_SCALE);
    ivec2 t0 = ivec2(floor(c));
    vec2 f = c - vec2(t0);
    vec4 sum = vec4(0.0);
    float wsum = 0.0;
    float best = 3.0e38;
    vec4 nearest = fallback;
    for (int i = 0; i < 4; ++i) {
        ivec2 o = ivec2(i & 1, i >> 1);
        ivec2 t = clamp(t0 + o, ivec2(0), size - 1);
        ivec2 q = ssao_sample_pixel(t);
        GBuffer h = gbuffer_load(q);
        if (h.alpha <= 0.0 || !(h.depth > 0.0)) continue;
        vec4 v = texelFetch(low, t, 0);
        vec2 qf = vec2(q) + 0.5;
        vec3 nq = to_view(shading_normal(h.normal, -view_ray_ws(qf)));
        vec3 pq = view_position(qf, u_resolution, h.depth, u_tan_half_fov);
        float bilinear = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
        float w = ssao_upsample_weight(bilinear, p, n, pq, nq);
        sum += w * v;
        wsum += w;
        float dz = abs(h.depth - g.depth);
        if (dz < best) {
            best = dz;
            nearest = v;
        }
    }
    return wsum > 1e-6 ? sum / wsum : nearest;
}

// The depth- and normal-aware (bilateral) blur of a full-resolution occlusion target `ao` at
// pixel `pixel` (G-buffer g, a surface), against the per-pixel noise of a few rays: a 5 x 5
// window with binomial weights (1 4 6 4 1 per axis) times ssao_upsample_weight's plane and normal
// terms, so a tap on another surface (beyond 2 % of the pixel's depth from its tangent plane, or
// turned away) drops out and nothing bleeds across a depth or crease edge. Taps outside the frame
// or on the background drop out; the pixel itself always has weight 36, so the sum is never 0.
// On a flat region the mean of independent noise keeps (70 / 256)^2 = 7.5 % of its variance.
vec4 ssao_blur(sampler2D ao, ivec2 pixel, GBuffer g) {
    const float binomial[5] = float[5](1.0, 4.0, 6.0, 4.0, 1.0);
    vec2 frag = vec2(pixel) + 0.5;
    vec3 n = to_view(shading_normal(g.normal, -view_ray_ws(frag)));
    vec3 p = view_position(frag, u_resolution, g.depth, u_tan_half_fov);
    ivec2 size = ivec2(u_resolution);
    vec4 sum = vec4(0.0);
    float wsum = 0.0;
    for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
            ivec2 q = pixel + ivec2(i, j);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            GBuffer h = gbuffer_load(q);
            if (h.alpha <= 0.0 || !(h.depth > 0.0)) continue;
            vec2 qf = vec2(q) + 0.5;
            vec3 nq = to_view(shading_normal(h.normal, -view_ray_ws(qf)));
            vec3 pq = view_position(qf, u_resolution, h.depth, u_tan_half_fov);
            float w = ssao_upsample_weight(binomial[i + 2] * binomial[j + 2], p, n, pq, nq);
            sum += w * texelFetch(ao, q, 0);
            wsum += w;
        }
    }
    return sum / wsum;
}

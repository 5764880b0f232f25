// ssao_upsample.glsl - what the SSAO passes at reduced scale share (SSAO_SCALE = k > 1 renders
// one pixel of k x k: render.ssao_scale): which full-resolution pixel a low-resolution texel
// stands for, and the joint bilateral upsampling of a low-resolution result to a full-resolution
// pixel (weights: lib/ssao.glsl ssao_upsample_weight). Pass-level chunk: needs passes/deferred.glsl
// (G-buffer, camera uniforms), lib/shading.glsl and lib/ssao.glsl included first.
// Twins: learned/twins/ssao.py (ssao_sample_pixel, ssao_upsample).
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

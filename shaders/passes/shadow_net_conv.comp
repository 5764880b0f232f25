// shadow_net_conv.comp - one layer of the neural shadow estimator (viewer/neural/shadow_net.py
// plan): a convolution over a tiled feature map (lib/shadow_net.glsl), one invocation per output
// pixel computing every output channel, weights from a uniform block (viewer/neural/shadow_net.py
// pack_layer: per tap, input slice and output slice the columns of a mat4, then the biases).
// Defines:
//   SN_KERNEL 1 | 2 | 3, SN_STRIDE 1 | 2 (2: the 2 x 2 taps at 2p), replicate padding
//   SN_A_SOURCE / SN_B_SOURCE: 0 none, 1 a map at the output's level, 2 a map at half the
//     output's resolution upsampled nearest, 3 the same bilinear (1 x 1 kernels only), 4 the
//     frame's inputs (radiance, G-buffer, SSAO's O(x) and S(x): lib/shadow_net.glsl
//     shadow_net_input_a / _b / _c)
//   SN_A_SLICES, SN_B_SLICES, SN_OUT_SLICES: RGBA texels per pixel of each
//   SN_ACT 0 relu | 1 sigmoid; SN_GAIN: the activation's factor (the output layer's gain g,
//     1 elsewhere); SN_WEIGHTS: vec4s of the weights
//   SN_ENV_VIS 1: the frame's S(x) input from u_ssao's g channel; 0: 1 (an estimator that does
//     not read it: architecture "env_visibility": false)
//   SN_DEMODULATE 1: the radiance input over the G-buffer's base colour (architecture
//     "demodulate": shadow_net_demodulate)
//   SN_OUTPUT 0: the result into the tiled map u_out; 1: the visibility (3 channels) multiplied
//     into the radiance image u_out in place where there is a surface (the product form)
// Twin: learned.twins.shadow_net.shadow_net_conv.
#define GBUFFER_READ
#include "generated/gbuffer.glsl"
#include "lib/shadow_net.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(std140) uniform ShadowNetLayer { vec4 u_w[SN_WEIGHTS]; };

uniform sampler2D u_a;
uniform ivec2 u_a_size;   // the level size of source A (texels, one slice)
uniform sampler2D u_b;
uniform ivec2 u_b_size;
uniform ivec2 u_out_size;  // the output's level size
uniform ivec2 u_frame_size;
uniform sampler2D u_radiance;  // the unshadowed radiance (SN_OUTPUT 0 with a frame source)
uniform sampler2D u_ssao;      // r: O(x), g: S(x) (SSAO_ENV_VIS)
uniform mat3 u_view_rotation;  // world -> view: the estimator reads view-space normals
layout(rgba32f) uniform image2D u_out;

#define SN_IN_SLICES (SN_A_SLICES + SN_B_SLICES)

vec4 frame_radiance(ivec2 q) {
#if SN_OUTPUT == 1
    return imageLoad(u_out, q);  // only at the invocation's own pixel (1 x 1 at full resolution)
#else
    return texelFetch(u_radiance, q, 0);
#endif
}

vec4 frame_input(ivec2 q, int s) {
    q = clamp(q, ivec2(0), u_frame_size - 1);
    if (s == 0) {
        vec3 radiance = frame_radiance(q).rgb;
#if SN_DEMODULATE
        radiance = shadow_net_demodulate(radiance, gbuffer_load(q).albedo);
#endif
        return shadow_net_input_a(radiance, texelFetch(u_ssao, q, 0).r);
    }
    if (s == 2) {
        return shadow_net_input_c(SN_ENV_VIS != 0 ? texelFetch(u_ssao, q, 0).g : 1.0);
    }
    GBuffer g = gbuffer_load(q);
    return shadow_net_input_b(u_view_rotation * g.normal, g.depth);
}

vec4 source(sampler2D map, ivec2 size, int kind, ivec2 q, int s) {
    if (kind == 4) {
        return frame_input(q, s);
    }
    if (kind == 2) {
        return shadow_net_fetch(map, clamp(q, ivec2(0), u_out_size - 1) >> 1, s, size);
    }
    if (kind == 3) {
        vec4 tx = shadow_net_up_taps(q.x, size.x);
        vec4 ty = shadow_net_up_taps(q.y, size.y);
        ivec2 i0 = ivec2(tx.x, ty.x), i1 = ivec2(tx.y, ty.y);
        vec4 top = tx.z * shadow_net_fetch(map, i0, s, size)
                 + tx.w * shadow_net_fetch(map, ivec2(i1.x, i0.y), s, size);
        vec4 bottom = tx.z * shadow_net_fetch(map, ivec2(i0.x, i1.y), s, size)
                    + tx.w * shadow_net_fetch(map, i1, s, size);
        return ty.z * top + ty.w * bottom;
    }
    return shadow_net_fetch(map, q, s, size);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, u_out_size))) {
        return;
    }
    vec4 acc[SN_OUT_SLICES];
    for (int o = 0; o < SN_OUT_SLICES; ++o) {
        acc[o] = u_w[SN_WEIGHTS - SN_OUT_SLICES + o];
    }
    for (int t = 0; t < SN_KERNEL * SN_KERNEL; ++t) {
        ivec2 d = ivec2(t % SN_KERNEL, t / SN_KERNEL);
        ivec2 q = SN_STRIDE == 2 ? 2 * p + d : p + d - SN_KERNEL / 2;
        for (int i = 0; i < SN_IN_SLICES; ++i) {
            vec4 v = i < SN_A_SLICES ? source(u_a, u_a_size, SN_A_SOURCE, q, i)
                                     : source(u_b, u_b_size, SN_B_SOURCE, q, i - SN_A_SLICES);
            int base = ((t * SN_IN_SLICES + i) * SN_OUT_SLICES) * 4;
            for (int o = 0; o < SN_OUT_SLICES; ++o) {
                int w = base + 4 * o;
                acc[o] += mat4(u_w[w], u_w[w + 1], u_w[w + 2], u_w[w + 3]) * v;
            }
        }
    }
#if SN_OUTPUT == 1
    vec4 radiance = imageLoad(u_out, p);
    GBuffer g = gbuffer_load(p);
    if (g.alpha > 0.0 && g.depth > 0.0) {
        radiance.rgb *= float(SN_GAIN) * shadow_net_act(acc[0], SN_ACT).rgb;
    }
    imageStore(u_out, p, radiance);
#else
    for (int o = 0; o < SN_OUT_SLICES; ++o) {
        imageStore(u_out, ivec2(p.x + o * u_out_size.x, p.y),
                   float(SN_GAIN) * shadow_net_act(acc[o], SN_ACT));
    }
#endif
}

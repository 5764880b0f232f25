// shadow_net.glsl - the neural shadow estimator's per-pixel pieces (viewer/neural/shadow_net.py;
// thesis eq. 4.3): its inputs, activations, upsampling taps and the tiled feature-map fetch.
// A feature map of C channels at a level of size (w, h) is one RGBA32F texture of
// (w * ceil(C / 4), h) texels: slice s of pixel p at (p.x + s * w, p.y).
// Twins: learned/twins/shadow_net.py.

// The first four input channels: the unshadowed radiance log-compressed, log(1 + max(L, 0)),
// and the SSAO pass's occlusion O(x).
vec4 shadow_net_input_a(vec3 radiance, float ao) {
    return vec4(log(vec3(1.0) + max(radiance, vec3(0.0))), ao);
}

// The radiance over the surface's base colour, at least SHADOW_NET_ALBEDO_FLOOR per channel
// ("demodulate"): the light the surface receives, without its texture, so that texture detail
// does not read as geometry (the albedo demodulation of denoisers).
const float SHADOW_NET_ALBEDO_FLOOR = 0.05;
vec3 shadow_net_demodulate(vec3 radiance, vec3 albedo) {
    return radiance / max(albedo, vec3(SHADOW_NET_ALBEDO_FLOOR));
}

// The other four: the view-space normal (the pass rotates the G-buffer's) and the view depth
// as 1 / (1 + z), 0 on the background (z = 0).
vec4 shadow_net_input_b(vec3 normal, float depth) {
    return vec4(normal, depth > 0.0 ? 1.0 / (1.0 + depth) : 0.0);
}

// The last: the SSAO pass's screen-space visibility of the environment's light S(x)
// (SSAO_ENV_VIS), the directional evidence of cast shadows that O(x) averages away.
vec4 shadow_net_input_c(float visibility) {
    return vec4(visibility, 0.0, 0.0, 0.0);
}

// kind 0: relu; 1: the logistic sigmoid, 1 / (1 + exp(-x)).
vec4 shadow_net_act(vec4 x, int kind) {
    if (kind == 1) {
        return vec4(1.0) / (vec4(1.0) + exp(-x));
    }
    return max(x, vec4(0.0));
}

// Bilinear 2x upsampling along one axis (half-pixel centres, edges clamped; torch's
// interpolate(scale_factor=2, mode="bilinear", align_corners=False)): for fine pixel x of a
// source n texels long, (i0, i1, w0, w1) with the value w0 src[i0] + w1 src[i1].
vec4 shadow_net_up_taps(int x, int n) {
    int i = x >> 1;
    int j = (x & 1) == 0 ? i - 1 : i + 1;
    return vec4(float(i), float(clamp(j, 0, n - 1)), 0.75, 0.25);
}

// Slice s of pixel p of a tiled map whose level is size texels (p clamped: replicate padding).
vec4 shadow_net_fetch(sampler2D map, ivec2 p, int s, ivec2 size) {
    ivec2 q = clamp(p, ivec2(0), size - 1);
    return texelFetch(map, ivec2(q.x + s * size.x, q.y), 0);
}

// accumulate.frag - progressive Monte-Carlo accumulation: the running mean of batches in float32,
//   mean_new = mean_old + (batch - mean_old) * u_weight,  u_weight = n_batch / (n_old + n_batch).
// u_weight >= 1 (the first batch) ignores the history, whatever it holds.
uniform sampler2D u_batch;    // this batch's mean (RGBA32F)
uniform sampler2D u_history;  // the mean so far (RGBA32F)
uniform float u_weight;
in vec2 v_uv;
layout(location = 0) out vec4 o_radiance;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 batch = texelFetch(u_batch, pixel, 0);
    if (u_weight >= 1.0) {
        o_radiance = batch;
        return;
    }
    vec4 history = texelFetch(u_history, pixel, 0);
    o_radiance = history + (batch - history) * u_weight;
}

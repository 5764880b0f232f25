// rt_accumulate.frag - the real-time tier's temporal accumulation: the running mean of the ray
// pass's three targets while the view and the scene stay still (viewer/passes/rt_light.py
// restarts it on any change, so nothing of an earlier view lingers: no ghosting), at most
// u_window frames deep (then an exponential average of that window).
uniform sampler2D u_new0;
uniform sampler2D u_new1;
uniform sampler2D u_new2;
uniform sampler2D u_old0;
uniform sampler2D u_old1;
uniform sampler2D u_old2;
uniform float u_weight;  // 1 / frames so far (1: the first frame, the history ignored)
in vec2 v_uv;
layout(location = 0) out vec4 o_0;
layout(location = 1) out vec4 o_1;
layout(location = 2) out vec4 o_2;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 n0 = texelFetch(u_new0, pixel, 0);
    vec4 n1 = texelFetch(u_new1, pixel, 0);
    vec4 n2 = texelFetch(u_new2, pixel, 0);
    if (u_weight >= 1.0) {
        o_0 = n0; o_1 = n1; o_2 = n2;
        return;
    }
    o_0 = mix(texelFetch(u_old0, pixel, 0), n0, u_weight);
    o_1 = mix(texelFetch(u_old1, pixel, 0), n1, u_weight);
    o_2 = mix(texelFetch(u_old2, pixel, 0), n2, u_weight);
}

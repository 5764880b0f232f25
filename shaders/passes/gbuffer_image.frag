// gbuffer_image.frag - copy an image-space G-buffer stack into the G-buffer (fullscreen pass).
// The stack's attachments are bound as u_gbuffer<i> (uploaded in GL row order, as a G-buffer). Background pixels (alpha = 0) are discarded, so meshes drawn before stay;
// foreground pixels write gl_FragDepth from the stored view depth so later meshes depth-test
// against the stack.
#define GBUFFER_WRITE
#define GBUFFER_READ
#include "generated/gbuffer.glsl"

uniform mat4 u_projection;  // the stack camera's view -> clip

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    GBuffer g = gbuffer_load(xy);
    if (g.alpha <= 0.0) {
        discard;
    }
    if (g.depth > 0.0) {
        // z_ndc depends only on z_vs for a perspective projection.
        vec4 clip = u_projection * vec4(0.0, 0.0, -g.depth, 1.0);
        gl_FragDepth = clamp(clip.z / clip.w * 0.5 + 0.5, 0.0, 1.0);
    } else {
        // no depth (or a layout without the depth channel): behind everything, but in front of
        // the cleared depth 1.0 so the LESS test keeps the pixel (0.9999999 < 1 in 24 bits)
        gl_FragDepth = 0.9999999;
    }
    gbuffer_store(g);
}

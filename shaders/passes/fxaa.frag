// fxaa.frag - FXAA 3.11 (lib/antialias.glsl fxaa) on the display image: the tone-mapped,
// sRGB-encoded pixels (FXAA's edge thresholds are set for perceptual luma), into the display.
// Twin: learned.twins.antialias.fxaa.
#include "lib/antialias.glsl"

uniform sampler2D u_display;
layout(location = 0) out vec4 o_color;

void main() {
    o_color = fxaa(u_display, gl_FragCoord.xy);
}

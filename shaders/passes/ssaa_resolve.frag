// ssaa_resolve.frag - supersampling's box resolve (lib/antialias.glsl ssaa_resolve): the radiance
// rendered at SSAA times the size, averaged over each output pixel's SSAA x SSAA block in linear
// radiance, before tone mapping. Defines: SSAA (>= 2). Twin: learned.twins.antialias.ssaa_resolve.
#include "lib/antialias.glsl"

uniform sampler2D u_radiance;
layout(location = 0) out vec4 o_radiance;

void main() {
    o_radiance = ssaa_resolve(u_radiance, ivec2(gl_FragCoord.xy), SSAA);
}

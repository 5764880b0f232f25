// parity_sh_irradiance.comp - lib/sh.glsl's sh_irradiance with the coefficients as a uniform array,
// for the parity check against learned.twins.sh (learned/parity/checks/ibl.py).
#include "lib/sh.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform vec3 u_sh[9];
layout(std430, binding = 0) readonly buffer In { float inv[]; };
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 e = sh_irradiance(vec3(inv[3u * i], inv[3u * i + 1u], inv[3u * i + 2u]), u_sh);
    outv[3u * i] = e.x; outv[3u * i + 1u] = e.y; outv[3u * i + 2u] = e.z;
}

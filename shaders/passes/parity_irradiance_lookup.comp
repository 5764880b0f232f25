// parity_irradiance_lookup.comp - lib/ibl.glsl's irradiance_lookup on a list of normals, for the
// parity check against learned.twins.ibl (learned/parity/checks/ibl.py).
#include "lib/ibl.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
uniform sampler2D u_irradiance;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [n][3] normal
layout(std430, binding = 1) writeonly buffer Out { float outv[]; }; // [n][3] rgb
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 e = irradiance_lookup(u_irradiance, vec3(inv[3u * i], inv[3u * i + 1u], inv[3u * i + 2u]));
    outv[3u * i] = e.x; outv[3u * i + 1u] = e.y; outv[3u * i + 2u] = e.z;
}

// neural_student.comp - the generated student MLP alone on a batch: neural_student_weights of
// "generated/neural_student.glsl" (viewer/neural/glsl.py, any weight storage) per item. Used by
// the neural:network parity check (learned/twins/neural.py) and the throughput bench
// (relight/bench/neural.py); viewer.neural.kernels reads the work-group size from this file.
// Planar layout: input k of item i at inv[k * u_count + i] (k < 12, the order of
// viewer.neural.STUDENT_ALL_INPUTS; a student ignores the inputs it does not read), output k at outv[k * u_count + i] (k < 6; a pbr3 student writes 3,
// then zeros): neighbouring invocations read neighbouring floats. Interleaved items
// (inv[10 i + k]) with 64 invocations per group took 4.4 ms for 65,536 items of the 8-32-32-6
// student on llvmpipe with the previous mat4 code, this layout with 256 per group and the column
// form 3.0 ms.
#include "lib/common.glsl"
#include "generated/neural_student.glsl"
layout(local_size_x = 256) in;
uniform uint u_count;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [12][n]
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [6][n]
void main() {
    uint i = gl_GlobalInvocationID.x;
    uint n = u_count;
    if (i >= n) return;
    vec3 k0;
    vec3 k1;
    neural_student_weights(vec3(inv[i], inv[n + i], inv[2u * n + i]), inv[3u * n + i],
                           inv[4u * n + i], inv[5u * n + i], inv[6u * n + i], inv[7u * n + i],
                           vec2(inv[8u * n + i], inv[9u * n + i]), inv[10u * n + i],
                           inv[11u * n + i], k0, k1);
    outv[i] = k0.x;
    outv[n + i] = k0.y;
    outv[2u * n + i] = k0.z;
    outv[3u * n + i] = k1.x;
    outv[4u * n + i] = k1.y;
    outv[5u * n + i] = k1.z;
}

// denoise.glsl - the edge-stopping weights of the real-time tier's a-trous filter
// (passes/rt_filter.frag; Dammertz et al. 2010, "Edge-Avoiding A-Trous Wavelet Transform for
// fast Global Illumination Filtering", and Schied et al. 2017, "Spatiotemporal Variance-Guided
// Filtering", eqs. 3-4 without the luminance term). No uniforms, no main.
// Twins: learned/twins/denoise.py.
#include "lib/common.glsl"

// The B3-spline kernel's 1D weight of tap offset k in {-2, -1, 0, 1, 2}: 1/16, 1/4, 3/8.
float atrous_kernel(float k) {
    float a = abs(k);
    return a < 0.5 ? 0.375 : (a < 1.5 ? 0.25 : 0.0625);
}

// How much a tap q counts for the centre p: exp of minus the depth difference relative to the
// centre's depth (sigma_z relative: a plane seen at a slant keeps its neighbours within the
// step's distance) times the normals' agreement raised to sigma_n (128: normals more than ~10
// degrees apart barely mix). 0 for taps off the surface (depth <= 0).
float atrous_edge_weight(float depth_p, float depth_q, vec3 n_p, vec3 n_q, float step_px,
                         float sigma_z, float sigma_n) {
    if (!(depth_q > 0.0) || !(depth_p > 0.0)) return 0.0;
    float dz = abs(depth_p - depth_q) / (sigma_z * depth_p * max(step_px, 1.0) + 1e-6);
    float w_n = pow(max(dot(n_p, n_q), 0.0), sigma_n);
    return exp(-dz) * w_n;
}

// sh.glsl - real spherical harmonics, 3 bands (9 coefficients), and irradiance from radiance SH.
// Index order: (l, m) = (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2).
// Coefficients are radiance projections L_lm = integral L(w) Y_lm(w) dw (linear RGB, vec3 each).
// No uniforms, no main.
#include "lib/common.glsl"

// Ramamoorthi & Hanrahan 2001, "An Efficient Representation for Irradiance Environment Maps",
// eq. 3 (real SH basis in Cartesian form). n: unit vector; index in [0, 8], anything else -> 0.
float sh_basis(int index, vec3 n) {
    switch (index) {
        case 0: return 0.282094791773878;
        case 1: return 0.488602511902920 * n.y;
        case 2: return 0.488602511902920 * n.z;
        case 3: return 0.488602511902920 * n.x;
        case 4: return 1.092548430592079 * n.x * n.y;
        case 5: return 1.092548430592079 * n.y * n.z;
        case 6: return 0.315391565252520 * (3.0 * n.z * n.z - 1.0);
        case 7: return 1.092548430592079 * n.x * n.z;
        case 8: return 0.546274215296040 * (n.x * n.x - n.y * n.y);
    }
    return 0.0;
}

// Ramamoorthi & Hanrahan 2001, eq. 8-9: clamped-cosine lobe coefficient A_l of band l
// (A0 = pi, A1 = 2 pi / 3, A2 = pi / 4) for coefficient index in [0, 8].
float sh_cosine_lobe(int index) {
    return index == 0 ? PI : (index < 4 ? 2.0 * PI / 3.0 : 0.25 * PI);
}

// Ramamoorthi & Hanrahan 2001, eq. 7: irradiance E(n) = sum_lm A_l L_lm Y_lm(n) at unit normal n,
// clamped at 0 (band-limited ringing can dip below zero). Diffuse radiance is albedo / pi * E.
vec3 sh_irradiance(vec3 n, vec3[9] sh) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        e += sh[i] * (sh_cosine_lobe(i) * sh_basis(i, n));
    }
    return max(e, vec3(0.0));
}

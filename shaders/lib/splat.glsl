// splat.glsl - 3D Gaussian splatting maths: covariance from rotation and scale, EWA projection to
// a 2D screen-space Gaussian, its conic and axes, per-fragment opacity, and the INRIA SH basis.
// Pixel units with the GL origin (bottom-left); view space looks down -Z. No uniforms, no main.
// Twins: learned/twins/splat.py.

// 3D Gaussian Splatting - Kerbl et al. 2023, sec. 4: rotation of the unit quaternion
// q = (w, x, y, z) (normalised here, so files may store any non-zero length). A zero quaternion
// gives the identity, as in the reference implementation (torch's normalize leaves 0 at 0, and
// the formula below maps 0 to I) instead of NaN.
mat3 splat_rotation(vec4 q) {
    float len2 = dot(q, q);
    q = len2 > 0.0 ? q * inversesqrt(len2) : vec4(0.0);
    float w = q.x, x = q.y, y = q.z, z = q.w;
    // mat3 constructor is column-major: columns are the images of the local axes
    return mat3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y),
                2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x),
                2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y));
}

// Kerbl et al. 2023, eq. 6: Sigma = R S S^T R^T. Diagonal (xx, yy, zz).
vec3 splat_cov3d_diag(vec4 q, vec3 sigma) {
    mat3 m = splat_rotation(q) * mat3(sigma.x, 0.0, 0.0, 0.0, sigma.y, 0.0, 0.0, 0.0, sigma.z);
    mat3 c = m * transpose(m);
    return vec3(c[0][0], c[1][1], c[2][2]);
}

// Kerbl et al. 2023, eq. 6: off-diagonal entries of Sigma, (xy, xz, yz).
vec3 splat_cov3d_offdiag(vec4 q, vec3 sigma) {
    mat3 m = splat_rotation(q) * mat3(sigma.x, 0.0, 0.0, 0.0, sigma.y, 0.0, 0.0, 0.0, sigma.z);
    mat3 c = m * transpose(m);
    return vec3(c[1][0], c[2][0], c[2][1]);
}

// The Gaussian's shortest axis (unit): the normal of a flat splat (GaussianShader, GS-IR).
// Ties pick the lowest axis index.
vec3 splat_min_axis(vec4 q, vec3 sigma) {
    mat3 r = splat_rotation(q);
    int k = sigma.x <= sigma.y ? (sigma.x <= sigma.z ? 0 : 2) : (sigma.y <= sigma.z ? 1 : 2);
    return r[k];
}

// The view-space depth (distance in front of the eye along the view axis) of world point p, with
// view_row2 = row 2 of the world -> view matrix: -(v20 p.x + v21 p.y + v22 p.z + v23). This is the
// quantity that culls a splat at the near and far planes, a yes/no decision: `precise` forbids the
// compiler to fuse or reorder the operations, so the result is the one sequence of correctly rounded
// float32 products and sums (GLSL 4.x requires a * b and a + b correctly rounded) and the torch twin
// reproduces it bit for bit on any conforming GL. A matrix product (u_view * p) may be contracted
// into FMAs differently by every driver, which moved splats within an ulp of the near plane across
// it on one side only.
float splat_view_depth(vec4 view_row2, vec3 p) {
    precise float a = view_row2.x * p.x;
    precise float b = view_row2.y * p.y;
    precise float c = view_row2.z * p.z;
    precise float d = ((a + b) + c) + view_row2.w;
    return -d;
}

// EWA Splatting - Zwicker et al. 2002, eq. 31 (local affine approximation of the projection), as
// in Kerbl et al. 2023 eq. 5: Sigma' = J W Sigma W^T J^T. t_vs: the centre in view space;
// cov_diag/cov_offdiag: the view-space covariance (xx, yy, zz) / (xy, xz, yz);
// focal_tan = (fx, fy, tan(fov_x / 2), tan(fov_y / 2)) with f in pixels. x/z and y/z are clamped
// to 1.3 tan(fov / 2) so splats far outside the view do not explode; 0.3 px^2 is added to the
// diagonal (a low-pass filter that also bounds the footprint below). Returns (a, b, c) of the
// symmetric 2D covariance [[a, b], [b, c]] in pixels^2.
vec3 splat_cov2d(vec3 t_vs, vec3 cov_diag, vec3 cov_offdiag, vec4 focal_tan) {
    float z = -t_vs.z;  // positive depth
    vec2 lim = 1.3 * focal_tan.zw;
    float xz = clamp(t_vs.x / z, -lim.x, lim.x);
    float yz = clamp(t_vs.y / z, -lim.y, lim.y);
    // rows of J with respect to (x, y, z_vs): u = cx + fx x / (-z_vs)
    vec3 j0 = vec3(focal_tan.x / z, 0.0, focal_tan.x * xz / z);
    vec3 j1 = vec3(0.0, focal_tan.y / z, focal_tan.y * yz / z);
    mat3 s = mat3(cov_diag.x, cov_offdiag.x, cov_offdiag.y,
                  cov_offdiag.x, cov_diag.y, cov_offdiag.z,
                  cov_offdiag.y, cov_offdiag.z, cov_diag.z);
    vec3 s0 = s * j0;
    vec3 s1 = s * j1;
    return vec3(dot(j0, s0) + 0.3, dot(j0, s1), dot(j1, s1) + 0.3);
}

// The determinant of splat_cov2d's result for Sigma = M M^T, M = [m0 m1 m2] the view-space
// covariance factor (columns sigma_k W r_k), without the cancellation of a c - b^2: with the rows
// t_i = M^T j_i of J M, det(J M M^T J^T + 0.3 I) = |t0 x t1|^2 + 0.3 (|t0|^2 + |t1|^2) + 0.09
// (Cauchy-Binet). For a needle (sigmas 1e4 and 1e-8) a c - b^2 is rounding noise ~1e-7 a c, far
// above the true value; each minor here is sigma_i sigma_j times an O(f^2 / z^2) 2x2 minor of J W R.
// Same Jacobian (and clamp) as splat_cov2d.
float splat_cov2d_det(vec3 t_vs, vec3 m0, vec3 m1, vec3 m2, vec4 focal_tan) {
    float z = -t_vs.z;
    vec2 lim = 1.3 * focal_tan.zw;
    float xz = clamp(t_vs.x / z, -lim.x, lim.x);
    float yz = clamp(t_vs.y / z, -lim.y, lim.y);
    vec3 j0 = vec3(focal_tan.x / z, 0.0, focal_tan.x * xz / z);
    vec3 j1 = vec3(0.0, focal_tan.y / z, focal_tan.y * yz / z);
    vec3 t0 = vec3(dot(m0, j0), dot(m1, j0), dot(m2, j0));
    vec3 t1 = vec3(dot(m0, j1), dot(m1, j1), dot(m2, j1));
    vec3 x = cross(t0, t1);
    return dot(x, x) + 0.3 * (dot(t0, t0) + dot(t1, t1)) + 0.09;
}

// Inverse of the 2D covariance (a, b, c) as (A, B, C): d^2 = A dx^2 + 2 B dx dy + C dy^2. det: its
// determinant a c - b^2, from splat_cov2d_det (accurate where a c - b^2 in float cancels).
vec3 splat_conic(vec3 cov2d, float det) {
    return vec3(cov2d.z, -cov2d.y, cov2d.x) / det;
}

// Eigen-decomposition of the 2D covariance: (lambda1, lambda2, e1.x, e1.y), lambda1 >= lambda2,
// e1 the unit major axis (e2 = (-e1.y, e1.x)). det as for splat_conic: lambda2 = det / lambda1,
// not mid - r, which cancels to noise (even a negative value, a NaN quad) for needle splats.
vec4 splat_axes(vec3 cov2d, float det) {
    float mid = 0.5 * (cov2d.x + cov2d.z);
    float half_diff = 0.5 * (cov2d.x - cov2d.z);
    float r = sqrt(half_diff * half_diff + cov2d.y * cov2d.y);
    float l1 = mid + r;
    float l2 = det / l1;
    // the eigenvector is (b, l1 - a) = (l1 - c, b) up to scale; l1 - a = r - (a - c) / 2 cancels
    // when a > c and |b| << a - c, so take the form whose subtraction adds: l1 - c for a >= c
    vec2 e1 = abs(cov2d.y) <= 1e-12 ? (cov2d.x >= cov2d.z ? vec2(1.0, 0.0) : vec2(0.0, 1.0))
            : cov2d.x >= cov2d.z ? normalize(vec2(l1 - cov2d.z, cov2d.y))
                                 : normalize(vec2(cov2d.y, l1 - cov2d.x));
    return vec4(l1, l2, e1);
}

// Squared Mahalanobis distance of the pixel offset d from the centre under the conic.
float splat_mahalanobis2(vec2 d, vec3 conic) {
    return conic.x * d.x * d.x + 2.0 * conic.y * d.x * d.y + conic.z * d.y * d.y;
}

// Kerbl et al. 2023, eq. 3 and their rasteriser: alpha = min(0.99, opacity exp(-d^2 / 2)); 0 where
// d^2 > 8 (outside the sqrt(8)-sigma quad) or alpha < 1/255 (skipped).
float splat_alpha(float opacity, float d2) {
    if (d2 > 8.0) {
        return 0.0;
    }
    float a = min(0.99, opacity * exp(-0.5 * d2));
    return a < 1.0 / 255.0 ? 0.0 : a;
}

// The INRIA 3DGS real SH basis (utils/sh_utils.py, signs folded in) at unit direction d, index
// 0..15 (degree 0..3); anything else -> 0. Colour = sum_k basis_k(d) sh_k + 0.5.
float splat_sh_basis(int index, vec3 d) {
    float x = d.x, y = d.y, z = d.z;
    float xx = x * x, yy = y * y, zz = z * z;
    switch (index) {
        case 0: return 0.28209479177387814;
        case 1: return -0.4886025119029199 * y;
        case 2: return 0.4886025119029199 * z;
        case 3: return -0.4886025119029199 * x;
        case 4: return 1.0925484305920792 * x * y;
        case 5: return -1.0925484305920792 * y * z;
        case 6: return 0.31539156525252005 * (2.0 * zz - xx - yy);
        case 7: return -1.0925484305920792 * x * z;
        case 8: return 0.5462742152960396 * (xx - yy);
        case 9: return -0.5900435899266435 * y * (3.0 * xx - yy);
        case 10: return 2.890611442640554 * x * y * z;
        case 11: return -0.4570457994644658 * y * (4.0 * zz - xx - yy);
        case 12: return 0.3731763325901154 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy);
        case 13: return -0.4570457994644658 * x * (4.0 * zz - xx - yy);
        case 14: return 1.445305721320277 * z * (xx - yy);
        case 15: return -0.5900435899266435 * x * (xx - 3.0 * yy);
    }
    return 0.0;
}

// n flipped, if needed, to face the camera (to_camera: from the splat towards the eye).
vec3 splat_face_forward(vec3 n, vec3 to_camera) {
    return dot(n, to_camera) < 0.0 ? -n : n;
}

// ---- median depth (the `splat_depth = "median"` option) ------------------------------------------
// The depth where the accumulated opacity of the splats, front to back, reaches half of the
// pixel's total coverage (splats plus what lies under them): the weighted median of the blending
// weights T_i alpha_i whose mean is eq. 6.10's expected depth. Floaters in front of a surface
// pull the mean towards the camera; the median stays on the surface unless they cover more than
// half. Found per pixel by a search over the splats' view depths: the range [min, max] of the
// contributing depths is split at SPLAT_MEDIAN_SPLITS thresholds, one pass multiplies the
// transmittance prod (1 - alpha_i) of the splats at or in front of each threshold, and the first
// threshold whose transmittance is at or below 1 - target narrows the range; after the last
// level, the nearest splat depth in the range is the answer (passes/splat_median.frag).

// The accumulated-opacity level the median crosses: half of the total coverage of splats (A) and
// what lies under them ((1 - A) under_alpha). Above A the median is the surface underneath.
float splat_median_target(float coverage, float under_alpha) {
    return 0.5 * (coverage + (1.0 - coverage) * under_alpha);
}

// Threshold k (0..17) of the depth range (lo, hi): lo + (hi - lo) k / 17, with `precise`
// products and sums in a fixed order, so the torch twin reproduces it bit for bit (a splat's
// "at or in front of the threshold" test must agree exactly).
float splat_depth_threshold(vec2 range, int k) {
    precise float t = float(k) * 0.058823529411764705;  // 1 / 17 (SPLAT_MEDIAN_SPLITS + 1)
    precise float d = range.x + (range.y - range.x) * t;
    return k >= 17 ? range.y : d;
}

// One search level: the transmittances t0..t3 (16 values, threshold k = 1..16 in order x, y, z,
// w of t0, then t1, ...) at the thresholds of `range`; returns the sub-range (threshold k - 1,
// threshold k) around the first k whose transmittance is <= t_target (k = 17, the range's end,
// if none is).
vec2 splat_depth_refine(vec2 range, float t_target, vec4 t0, vec4 t1, vec4 t2, vec4 t3) {
    float t[16] = float[16](t0.x, t0.y, t0.z, t0.w, t1.x, t1.y, t1.z, t1.w,
                            t2.x, t2.y, t2.z, t2.w, t3.x, t3.y, t3.z, t3.w);
    int k = 17;
    for (int i = 15; i >= 0; --i) {
        if (t[i] <= t_target) {
            k = i + 1;
        }
    }
    return vec2(splat_depth_threshold(range, k - 1), splat_depth_threshold(range, k));
}

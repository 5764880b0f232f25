"""Twins of ``shaders/lib/splat.glsl`` (Gaussian splatting maths) and the ``splats`` pass check.

Shapes: quaternions ``[..., 4]`` (w, x, y, z), sigmas ``[..., 3]``, 2D covariances and conics
``[..., 3]`` as (a, b, c) of [[a, b], [b, c]] in pixels^2. The pass check renders random scenes of
>= 1000 splats with the GLSL pipeline and with :func:`learned.splats.rasterize.rasterize` and
compares every G-buffer channel.
"""
from __future__ import annotations

import torch

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792,
         0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
         -0.4570457994644658, 1.445305721320277, -0.5900435899266435)


def splat_rotation(q: torch.Tensor) -> torch.Tensor:
    """GLSL ``mat3 splat_rotation(vec4 q)``: q [..., 4] (w, x, y, z), normalised here ->
    [..., 3, 3] with columns the rotated local axes (row-major indexing m[..., row, col]). A zero
    quaternion gives the identity (not NaN)."""
    len2 = (q * q).sum(-1, keepdim=True)
    safe = torch.where(len2 > 0, len2, torch.ones_like(len2))  # no inf/NaN gradient at q = 0
    q = torch.where(len2 > 0, q * torch.rsqrt(safe), torch.zeros_like(q))
    w, x, y, z = q.unbind(-1)
    return torch.stack([
        torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        torch.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        torch.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], dim=-2)


def _cov3d(q: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    m = splat_rotation(q) * sigma[..., None, :]
    return m @ m.transpose(-1, -2)


def splat_cov3d_diag(q: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_cov3d_diag(vec4 q, vec3 sigma)``: (xx, yy, zz) of R S S^T R^T."""
    return torch.diagonal(_cov3d(q, sigma), dim1=-2, dim2=-1)


def splat_cov3d_offdiag(q: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_cov3d_offdiag(vec4 q, vec3 sigma)``: (xy, xz, yz)."""
    c = _cov3d(q, sigma)
    return torch.stack([c[..., 0, 1], c[..., 0, 2], c[..., 1, 2]], -1)


def splat_view_depth(view_row2: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_view_depth(vec4 view_row2, vec3 p)``: -(((v20 x + v21 y) + v22 z) + v23),
    the same correctly rounded float32 operations in the same order (elementwise, no matmul), so
    the near/far cull decision is bit-identical to GLSL's."""
    v = view_row2.to(torch.float32)
    p = p.to(torch.float32)
    a = v[..., 0] * p[..., 0]
    b = v[..., 1] * p[..., 1]
    c = v[..., 2] * p[..., 2]
    return -(((a + b) + c) + v[..., 3])


def splat_min_axis(q: torch.Tensor, sigma: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_min_axis(vec4 q, vec3 sigma)``: the column of R for the smallest sigma
    (ties: lowest index)."""
    sx, sy, sz = sigma.unbind(-1)
    k = torch.where(sx <= sy, torch.where(sx <= sz, 0, 2), torch.where(sy <= sz, 1, 2))
    r = splat_rotation(q)
    return torch.gather(r, -1, k[..., None, None].expand(*r.shape[:-1], 1))[..., 0]


def splat_cov2d(t_vs: torch.Tensor, cov_diag: torch.Tensor, cov_offdiag: torch.Tensor,
                focal_tan: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_cov2d(vec3 t_vs, vec3 cov_diag, vec3 cov_offdiag, vec4 focal_tan)``:
    EWA 2D covariance (a, b, c) in pixels^2 with the 1.3 tan(fov/2) clamp and +0.3 dilation."""
    z = -t_vs[..., 2]
    fx, fy, tx, ty = focal_tan.unbind(-1)
    xz = torch.maximum(torch.minimum(t_vs[..., 0] / z, 1.3 * tx), -1.3 * tx)
    yz = torch.maximum(torch.minimum(t_vs[..., 1] / z, 1.3 * ty), -1.3 * ty)
    zero = torch.zeros_like(z)
    j0 = torch.stack([fx / z, zero, fx * xz / z], -1)
    j1 = torch.stack([zero, fy / z, fy * yz / z], -1)
    xx, yy, zz = cov_diag.unbind(-1)
    xy, xz_, yz_ = cov_offdiag.unbind(-1)
    s = torch.stack([torch.stack([xx, xy, xz_], -1), torch.stack([xy, yy, yz_], -1),
                     torch.stack([xz_, yz_, zz], -1)], -2)
    s0 = (s @ j0[..., None])[..., 0]
    s1 = (s @ j1[..., None])[..., 0]
    return torch.stack([(j0 * s0).sum(-1) + 0.3, (j0 * s1).sum(-1), (j1 * s1).sum(-1) + 0.3], -1)


def splat_cov2d_det(t_vs: torch.Tensor, m0: torch.Tensor, m1: torch.Tensor, m2: torch.Tensor,
                    focal_tan: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_cov2d_det(vec3 t_vs, vec3 m0, vec3 m1, vec3 m2, vec4 focal_tan)``: the
    determinant of :func:`splat_cov2d` for Sigma = M M^T (M's columns m0..m2 [..., 3]) by
    Cauchy-Binet, |t0 x t1|^2 + 0.3 (|t0|^2 + |t1|^2) + 0.09 with t_i = M^T j_i -> [...]."""
    z = -t_vs[..., 2]
    fx, fy, tx, ty = focal_tan.unbind(-1)
    xz = torch.maximum(torch.minimum(t_vs[..., 0] / z, 1.3 * tx), -1.3 * tx)
    yz = torch.maximum(torch.minimum(t_vs[..., 1] / z, 1.3 * ty), -1.3 * ty)
    zero = torch.zeros_like(z)
    j0 = torch.stack([fx / z, zero, fx * xz / z], -1)
    j1 = torch.stack([zero, fy / z, fy * yz / z], -1)
    t0 = torch.stack([(m * j0).sum(-1) for m in (m0, m1, m2)], -1)
    t1 = torch.stack([(m * j1).sum(-1) for m in (m0, m1, m2)], -1)
    x = torch.linalg.cross(t0, t1)
    return (x * x).sum(-1) + 0.3 * ((t0 * t0).sum(-1) + (t1 * t1).sum(-1)) + 0.09


def splat_conic(cov2d: torch.Tensor, det: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_conic(vec3 cov2d, float det)``: the inverse (A, B, C); det [...] from
    :func:`splat_cov2d_det`."""
    a, b, c = cov2d.unbind(-1)
    return torch.stack([c, -b, a], -1) / det[..., None]


def splat_axes(cov2d: torch.Tensor, det: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 splat_axes(vec3 cov2d, float det)``: (lambda1, lambda2 = det / lambda1, e1.x,
    e1.y)."""
    a, b, c = cov2d.unbind(-1)
    mid = 0.5 * (a + c)
    half_diff = 0.5 * (a - c)
    r = torch.sqrt(half_diff * half_diff + b * b)
    l1 = mid + r
    l2 = det / l1
    # (l1 - c, b) for a >= c, (b, l1 - a) otherwise: the subtraction that does not cancel
    v = torch.where((a >= c)[..., None], torch.stack([l1 - c, b], -1), torch.stack([b, l1 - a], -1))
    v = v / torch.linalg.vector_norm(v, dim=-1, keepdim=True).clamp_min(1e-30)
    ex = torch.where(a >= c, 1.0, 0.0)
    fallback = torch.stack([ex, 1.0 - ex], -1)
    e1 = torch.where((b.abs() > 1e-12)[..., None], v, fallback)
    return torch.cat([l1[..., None], l2[..., None], e1], -1)


def splat_mahalanobis2(d: torch.Tensor, conic: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_mahalanobis2(vec2 d, vec3 conic)``."""
    dx, dy = d.unbind(-1)
    a, b, c = conic.unbind(-1)
    return a * dx * dx + 2.0 * b * dx * dy + c * dy * dy


def splat_alpha(opacity: torch.Tensor, d2: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_alpha(float opacity, float d2)``: min(0.99, o exp(-d2/2)), 0 where
    d2 > 8 or alpha < 1/255."""
    a = torch.clamp(opacity * torch.exp(-0.5 * d2), max=0.99)
    keep = (d2 <= 8.0) & (a >= 1.0 / 255.0)
    return torch.where(keep, a, torch.zeros_like(a))


def splat_sh_basis_all(d: torch.Tensor, k: int = 16) -> torch.Tensor:
    """All INRIA 3DGS basis functions at unit directions d [..., 3] -> [..., k]."""
    x, y, z = d.unbind(-1)
    xx, yy, zz = x * x, y * y, z * z
    cols = [torch.full_like(x, SH_C0), -SH_C1 * y, SH_C1 * z, -SH_C1 * x,
            SH_C2[0] * x * y, SH_C2[1] * y * z, SH_C2[2] * (2 * zz - xx - yy), SH_C2[3] * x * z,
            SH_C2[4] * (xx - yy),
            SH_C3[0] * y * (3 * xx - yy), SH_C3[1] * x * y * z, SH_C3[2] * y * (4 * zz - xx - yy),
            SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy), SH_C3[4] * x * (4 * zz - xx - yy),
            SH_C3[5] * z * (xx - yy), SH_C3[6] * x * (xx - 3 * yy)]
    return torch.stack(cols[:k], -1)


def splat_sh_basis(index: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_sh_basis(int index, vec3 d)``: index [...] (0..15, else 0)."""
    idx = index.round().to(torch.int64) if index.is_floating_point() else index.to(torch.int64)
    all16 = splat_sh_basis_all(d)
    picked = torch.gather(all16, -1, idx.clamp(0, 15)[..., None])[..., 0]
    return torch.where((idx >= 0) & (idx <= 15), picked, torch.zeros_like(picked))


def splat_face_forward(n: torch.Tensor, to_camera: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 splat_face_forward(vec3 n, vec3 to_camera)``."""
    return torch.where(((n * to_camera).sum(-1) < 0.0)[..., None], -n, n)


# ---- median depth --------------------------------------------------------------------------------
MEDIAN_SPLITS = 16  # thresholds per search level (SPLAT_MEDIAN_SPLITS)
_INV17 = torch.tensor(0.058823529411764705, dtype=torch.float32)  # the GLSL literal, in float32


def splat_median_target(coverage: torch.Tensor, under_alpha: torch.Tensor) -> torch.Tensor:
    """GLSL ``float splat_median_target(float coverage, float under_alpha)``: half the pixel's
    total coverage, 0.5 (A + (1 - A) under_alpha)."""
    return 0.5 * (coverage + (1.0 - coverage) * under_alpha)


def splat_depth_threshold(range_: torch.Tensor, k: torch.Tensor | int) -> torch.Tensor:
    """GLSL ``float splat_depth_threshold(vec2 range, int k)``: range [..., 2] (lo, hi), k [...]
    (0..17) -> lo + (hi - lo) (k * float32(1 / 17)), the same float32 operations in the same
    order (bit-identical); k >= 17 gives hi."""
    lo, hi = range_[..., 0].to(torch.float32), range_[..., 1].to(torch.float32)
    k = torch.as_tensor(k)
    kf = (k.round() if k.is_floating_point() else k).to(torch.float32)
    t = kf * _INV17
    d = lo + (hi - lo) * t
    return torch.where(kf >= 17, hi, d)


def splat_depth_refine(range_: torch.Tensor, t_target: torch.Tensor, t0: torch.Tensor,
                       t1: torch.Tensor, t2: torch.Tensor, t3: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 splat_depth_refine(vec2 range, float t_target, vec4 t0, ..., vec4 t3)``:
    (threshold k - 1, threshold k) for the first k in 1..16 whose transmittance (t0.x, ...,
    t3.w) is <= t_target, k = 17 if none."""
    t = torch.cat([t0, t1, t2, t3], -1)  # [..., 16]
    hit = t <= t_target[..., None]
    first = torch.where(hit.any(-1), hit.to(torch.int64).argmax(-1) + 1, torch.full_like(
        hit[..., 0], 17, dtype=torch.int64))
    return torch.stack([splat_depth_threshold(range_, first - 1),
                        splat_depth_threshold(range_, first)], -1)

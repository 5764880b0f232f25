"""Twins of ``shaders/lib/splat.glsl`` (Gaussian splatting maths) and the ``splats`` pass check.

Shapes: quaternions ``[..., 4]`` (w, x, y, z), sigmas ``[..., 3]``, 2D covariances and conics
``[..., 3]`` as (a, b, c) of [[a, b], [b, c]] in pixels^2. The pass check renders random scenes of
>= 1000 splats with the GLSL pipeline and with :func:`learned.splats.rasterize.rasterize` and
compares every G-buffer channel.
"""
from __future__ import annotations

import numpy as np
import torch

from ._cases import Arg, ParityCase

# splat_rotation returns a mat3: covered by the "splats" pass check (the whole rasterizer).
PASS_LEVEL = ("splat_rotation",)

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
    v = torch.stack([b, l1 - a], -1)
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


def _spd_cov(args):
    """Make (diag, offdiag) a valid covariance: A A^T + small diagonal from the drawn entries."""
    t, diag, off, ft = args
    a = torch.tensor(diag).double()
    b = torch.tensor(off).double()
    m = torch.zeros(len(a), 3, 3, dtype=torch.float64)
    m[:, 0, 0], m[:, 1, 1], m[:, 2, 2] = a[:, 0], a[:, 1], a[:, 2]
    m[:, 1, 0], m[:, 2, 0], m[:, 2, 1] = b[:, 0], b[:, 1], b[:, 2]
    c = m @ m.transpose(1, 2) + 1e-4 * torch.eye(3, dtype=torch.float64)
    d = torch.stack([c[:, 0, 0], c[:, 1, 1], c[:, 2, 2]], -1).float().numpy()
    o = torch.stack([c[:, 0, 1], c[:, 0, 2], c[:, 1, 2]], -1).float().numpy()
    t = t.copy()
    t[:, 2] = -abs(t[:, 2]) - 0.2  # in front of the camera
    return [t, d, o, ft]


def _cov2d_valid(args):
    """2D covariances as the pipeline makes them: SPD with eigenvalues >= 0.3, and their
    determinant (computed in float64, as splat_cov2d_det delivers it)."""
    c = args[0].copy()
    c[:, 0] = abs(c[:, 0]) + 0.3
    c[:, 2] = abs(c[:, 2]) + 0.3
    lim = (c[:, 0] - 0.3) * (c[:, 2] - 0.3)
    c[:, 1] = c[:, 1].clip(-1, 1) * lim ** 0.5
    c64 = c.astype(np.float64)
    det = c64[:, 0] * c64[:, 2] - c64[:, 1] ** 2
    return [c, np.maximum(det, 0.09).astype(np.float32)]


def _in_front(args):
    """splat_cov2d_det inputs with the centre in front of the camera."""
    t = args[0].copy()
    t[:, 2] = -abs(t[:, 2]) - 0.2
    return [t, *args[1:]]


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("splat_cov3d_diag", (Arg(lo=-1, hi=1, components=4,
                                        adversarial=((1, 0, 0, 0), (0, 0, 0, 0))),
                                    Arg(lo=1e-3, hi=2.0, components=3)),
               atol=1e-6, rtol=2e-5, measured="max abs 5.3e-6, max rel 7.8e-6 (seeds 0-7)",
               envelope="R from q normalised by inversesqrt (2 ulp): entries off by ~8 x 2^-24; "
                        "c_ii = sum_k sigma_k^2 R_ik^2 (terms >= 0, 3x3 products in any order): "
                        "first-order on the draws (seeds 0-63) uses 90% of the tolerance"),
    ParityCase("splat_cov3d_offdiag", (Arg(lo=-1, hi=1, components=4,
                                           adversarial=((1, 0, 0, 0), (0, 0, 0, 0))),
                                       Arg(lo=1e-3, hi=2.0, components=3)),
               atol=1.6e-5, rtol=2e-5, measured="max abs 2.5e-6 (seeds 0-7; cancellation near 0)",
               envelope="c_ij = sum_k sigma_k^2 R_ik R_jk (sigma <= 2) cancels to ~0 from terms "
                        "<= 4 whose R entries are off by ~8 x 2^-24: first-order on the draws "
                        "(seeds 0-63) 1.5e-5 abs (atol widened from 1e-5)"),
    ParityCase("splat_min_axis", (Arg(lo=-1, hi=1, components=4),
                                  Arg(lo=1e-3, hi=2.0, components=3,
                                      adversarial=((0.1, 0.1, 0.1), (0.2, 0.1, 0.1)))),
               atol=2e-6, rtol=1e-5, measured="max abs 7.2e-7 (seeds 0-7)",
               envelope="a column of R: 2 (x y +- w z) or 1 - 2 (y^2 + z^2) of q normalised by "
                        "inversesqrt (2 ulp), terms <= 1 cancel: first-order on the draws 1.8e-6 "
                        "abs (atol widened from 1e-6); the axis choice compares inputs (exact)"),
    # bit-exact by construction (see the GLSL comment): any difference means a driver contracted
    # or reordered the `precise` operations, and the near-plane cull would differ again
    ParityCase("splat_view_depth", (Arg(lo=-1.0, hi=1.0, components=4,
                                        adversarial=((0.0, 0.0, -1.0, -3.0),
                                                     (0.1, 0.2, -0.97, 2.95))),
                                    Arg(lo=-3.0, hi=3.0, components=3,
                                        adversarial=((0.3, 0.2, 2.95), (1e-8, -1e-8, 3.0)))),
               atol=0.0, rtol=0.0, measured="exact (0 abs); nosse (x87): 9.5e-7 abs, see envelope",
               envelope="exact: `precise` fixes 3 correctly rounded products and 3 sums in "
                        "this order (GLSL: a * b, a + b correctly rounded), the twin does the "
                        "same; llvmpipe's nosse (x87) path keeps 80-bit intermediates and "
                        "violates this"),
    ParityCase("splat_cov2d", (Arg(lo=-3, hi=3, components=3), Arg(lo=-1, hi=1, components=3),
                               Arg(lo=-1, hi=1, components=3),
                               Arg(lo=0.2, hi=1.5, components=4,
                                   adversarial=((300.0, 300.0, 0.5, 0.5),))),
               atol=1e-4, rtol=2.5e-4, prepare=_spd_cov,
               measured="max rel 1.8e-7 (max abs 2e-3 on values ~1e5; seeds 0-7)",
               envelope="a, c = j.S j + 0.3 (S SPD); b = j0.S j1 cancels to |b| << sqrt(a c): "
                        "its error ~k 2^-24 |j0||S||j1| (mat3 x vec3, dot in any order/FMA) "
                        "is unbounded relative to b: first-order on the draws with the f = "
                        "300 px grid element (seeds 0-63) 2.45e-4 rel (rtol widened from 2e-5)"),
    ParityCase("splat_cov2d_det", (Arg(lo=-3, hi=3, components=3),
                                   Arg(lo=-1, hi=1, components=3,
                                       adversarial=((1e4, 0.0, 0.0), (0.0, 0.0, 0.0))),
                                   Arg(lo=-1, hi=1, components=3, adversarial=((0.0, 1e-8, 0.0),)),
                                   Arg(lo=-1, hi=1, components=3, adversarial=((0.0, 0.0, 1e-8),)),
                                   Arg(lo=0.2, hi=1.5, components=4,
                                       adversarial=((300.0, 300.0, 0.5, 0.5),))),
               atol=1e-6, rtol=2.5e-5, prepare=_in_front,
               measured="max rel 3.3e-7 (max abs 1.5e-3 on values ~1e4; seeds 0-7)",
               envelope="|t0 x t1|^2 + 0.3 (|t0|^2 + |t1|^2) + 0.09: the cross product's "
                        "minors cancel (~4 x 2^-24 |t0||t1| per side); against det >= 0.6 "
                        "|t0||t1| + |x|^2 that is <= k 2^-24 sqrt(|t0||t1|): first-order on the "
                        "draws (seeds 0-63) 2.3e-5 rel (rtol widened from 2e-5)"),
    ParityCase("splat_conic", (Arg(lo=-50, hi=50, components=3), Arg(lo=1.0, hi=2.0)),
               atol=1e-7, rtol=1e-5, measured="exact on llvmpipe", prepare=_cov2d_valid,
               envelope="(c, -b, a) / det, det an input: one division (2.5 ulp) + torch's 0.5 "
                        "-> 3.6e-7 rel"),
    ParityCase("splat_axes", (Arg(lo=-50, hi=50, components=3,
                                  adversarial=((2.0, 0.0, 1.0), (1.0, 0.0, 2.0), (1.0, 0.0, 1.0))),
                              Arg(lo=1.0, hi=2.0)),
               atol=7e-4, rtol=1e-5, measured="max abs 7.6e-6 (eigenvalues ~100; seeds 0-7)",
               prepare=_cov2d_valid,
               envelope="l1 = mid + sqrt(...) (4.5 ulp), l2 = det / l1: ~1e-6 rel; e1 = "
                        "normalize(b, l1 - a): l1 - a cancels for a > c, |b| << a - c -> ulps "
                        "of a (<= 50) / |b|: first-order on the draws (seeds 0-63) median 7e-5, "
                        "max 6.7e-4 abs (atol widened from 2e-5; heavy tail as b -> 0)"),
    ParityCase("splat_mahalanobis2", (Arg(lo=-10, hi=10, components=2),
                                      Arg(lo=-1, hi=1, components=3)),
               atol=1.5e-4, rtol=1e-5,
               measured="max abs 3.1e-5 on values ~400 (rel 9.6e-5 where terms cancel)",
               envelope="A dx^2 + 2 B dx dy + C dy^2, random conic indefinite: terms (<= 100, "
                        "200, 100) cancel; ~3 roundings per term per side (FMA any) -> 2 x 3 x "
                        "2^-24 x 400 = 1.4e-4 abs (atol widened from 1e-5; first-order on the "
                        "draws 7.3e-5)"),
    ParityCase("splat_alpha", (Arg(lo=0, hi=1, adversarial=(0.0, 1.0)),
                               Arg(lo=0, hi=12, adversarial=(0.0, 8.0, 8.0001))),
               atol=1e-6, rtol=1e-5, measured="max abs 1.8e-7 (seeds 0-7)",
               envelope="o exp(-d2 / 2): exp (3 + 2|x|) ulp with |x| <= 4 -> 11 ulp + product "
                        "-> 1.5e-6 rel; d2 > 8 compares the input; alpha < 1/255 flips only "
                        "within ~1e-8 of the cut"),
    ParityCase("splat_sh_basis", (Arg(kind="int", lo=-1, hi=16,
                                      adversarial=tuple(float(i) for i in range(16))),
                                  Arg(kind="unit", components=3,
                                      adversarial=((0.0, 1.0, 0.0), (0.0, 0.0, -1.0)))),
               atol=1e-6, rtol=1e-5, measured="max abs 6e-8 (seeds 0-7)",
               envelope="constant x <= 3 component products, 2 zz - xx - yy style "
                        "cancellations of terms <= 4: first-order 2.1e-7 abs near 0, 21% of "
                        "the tolerance"),
    ParityCase("splat_face_forward", (Arg(kind="unit", components=3),
                                      Arg(lo=-1, hi=1, components=3)),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: a negation; the sign of n.c could differ only within ~3 x "
                        "2^-24 |c| of 0 (p ~ 2e-3 over 4096 draws)"),
]


def _register() -> None:
    from learned.parity import register_pass_check

    @register_pass_check("splats", model="splats")
    def check(programs):
        from learned.splats.rasterize import parity_check

        return parity_check(programs)


_register()

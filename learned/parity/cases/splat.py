"""Parity cases of ``shaders/lib/splat.glsl`` against :mod:`learned.twins.splat`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

import numpy as np
import torch

from .base import Arg, ParityCase

# splat_rotation returns a mat3: covered by the "splats" pass check (the whole rasterizer).
PASS_LEVEL = ("splat_rotation",)


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
               atol=2e-6, rtol=2e-6,
               measured="max abs 7.6e-6 on eigenvalues ~100 (max rel 2.5e-7), seeds 0-7, on the "
                        "default and the SSE4.1/128-bit paths",
               prepare=_cov2d_valid,
               envelope="l1 = mid + sqrt(hd^2 + b^2): ~5 roundings + sqrt (1 / inversesqrt, 4.5 "
                        "ulp) ~ 1e-6 rel; l2 = det / l1: + 2.5 ulp; e1 = normalize of (l1 - c, b) "
                        "for a >= c, (b, l1 - a) otherwise: sums of same-sign terms, no "
                        "cancellation (the form used before cancelled for a > c, |b| << a - c and "
                        "needed atol 7e-4), ~10 ulp of a unit vector = 1.2e-6 abs"),
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


def _depth_ranges(args):
    """(lo, hi) depth ranges with lo <= hi, as the min/max pass makes them."""
    r = args[0].copy()
    r.sort(axis=1)
    return [r, *args[1:]]


PARITY_CASES += [
    ParityCase("splat_median_target", (Arg(lo=0, hi=1, adversarial=(0.0, 1.0, 0.5)),
                                       Arg(lo=0, hi=1, adversarial=(0.0, 1.0))),
               atol=1e-7, rtol=1e-6, measured="exact on llvmpipe",
               envelope="0.5 (A + (1 - A) u): 4 correctly rounded operations on values in [0, 1] "
                        "(an FMA may fuse one): <= 2 ulp of 1 = 1.2e-7"),
    # bit-exact by construction, as splat_view_depth: a splat's depth is compared against these
    # thresholds in GLSL and in the twin, and the comparison must agree
    ParityCase("splat_depth_threshold", (Arg(lo=0.05, hi=50.0, components=2,
                                             adversarial=((1.0, 1.0), (0.1, 100.0))),
                                         Arg(kind="int", lo=0, hi=17,
                                             adversarial=(0.0, 1.0, 16.0, 17.0))),
               atol=0.0, rtol=0.0, prepare=_depth_ranges, measured="exact (0 abs)",
               envelope="exact: `precise` fixes k * float32(1/17), hi - lo, the product and the "
                        "sum, each correctly rounded in GLSL and in the twin"),
    ParityCase("splat_depth_refine", (Arg(lo=0.05, hi=50.0, components=2),
                                      Arg(lo=0, hi=1, adversarial=(0.0, 0.5, 1.0)),
                                      Arg(lo=0, hi=1, components=4, adversarial=((1, 1, 1, 1),)),
                                      Arg(lo=0, hi=1, components=4, adversarial=((0.5,) * 4,)),
                                      Arg(lo=0, hi=1, components=4),
                                      Arg(lo=0, hi=1, components=4, adversarial=((0, 0, 0, 0),))),
               atol=0.0, rtol=0.0, prepare=_depth_ranges, measured="exact (0 abs)",
               envelope="exact: comparisons of the inputs pick k, then two "
                        "splat_depth_threshold values (bit-exact)"),
]

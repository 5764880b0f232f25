"""Parity cases of ``shaders/lib/ssao.glsl`` against :mod:`learned.twins.ssao`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase


def _upsample_geometry(args):
    """Make the drawn points of ssao_upsample_weight a full-resolution pixel and a nearby sample
    (q = p + offset up to 4 % of p's depth, in front of the camera) with normals near each
    other, so every term of the weight is exercised (the plane term's 2 % cut, cos^8 > 0)."""
    bil, p, n, off, nq = (np.array(a, np.float32, copy=True) for a in args)
    p[:, 2] = -np.abs(p[:, 2]) - 0.5
    q = (p + off * 0.04 * -p[:, 2:3]).astype(np.float32)
    nq = (nq + 2.0 * n).astype(np.float32)
    nq /= np.linalg.norm(nq, axis=1, keepdims=True)
    return [bil, p, n, q, nq.astype(np.float32)]

# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("view_position", (Arg(lo=0.0, hi=128.0, components=2), Arg(lo=16.0, hi=128.0,
                                 components=2), Arg(lo=0.1, hi=50.0, adversarial=(0.0,)),
                                 Arg(lo=0.05, hi=2.0, components=2)),
               atol=5e-5, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7); nosse: 6e-5 on "
                                               "values ~300 (rel 1.7e-7)",
               envelope="ndc = f / r * 2 - 1 cancels at the centre: f / r's 3 ulp (division 2.5 "
                        "+ 0.5) x 2 = 3.6e-7 abs, times tan <= 2 and depth <= 50 -> 3.6e-5 "
                        "abs (atol widened from 1e-6; first-order on the draws 4.6e-5); "
                        "elsewhere 3 roundings rel"),
    ParityCase("view_to_frag", (Arg(lo=-5.0, hi=5.0, components=3,
                                    adversarial=((0.0, 0.0, -1.0), (1.0, 1.0, 0.0))),
                                Arg(lo=16.0, hi=128.0, components=2),
                                Arg(lo=0.05, hi=2.0, components=2)),
               atol=1e-4, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7)",
               envelope="p.xy / (depth tan) (2.5 ulp + product), (ndc 0.5 + 0.5) res cancels "
                        "near ndc = -1: ulps of ndc x res / 2 <= 64 -> first-order 3.6e-5 abs, "
                        "38% of the tolerance; depth = -p.z exact"),
    ParityCase("surface_depth_at", (Arg(lo=-3.0, hi=3.0, components=3),
                                    Arg(lo=-3.0, hi=3.0, components=3),
                                    Arg(kind="unit", components=3, adversarial=((0, 0, 0),)),
                                    Arg(lo=0.1, hi=10.0)),
               atol=4e-5, rtol=1e-4,
               measured="max abs 1.9e-5, max rel 1.4e-3 (seeds 0-7; division by a small q.n "
                        "just above the 5% cut)",
               envelope="-q.z (p.n / q.n) with |q.n| > 0.05 |q|: p.n cancels, 3 x 2^-24 |p| "
                        "(<= 5.2) per side, times |q.z| / |q.n| < 20 -> 3.7e-5 abs (atol widened "
                        "from 1e-5); q.n's 60 x 2^-24 rel per side -> 7e-6 rel; the 5% cut may "
                        "flip within ~1e-6 rel of it (p ~ 1% per 4096 draws)"),
    ParityCase("ssao_occluded", (Arg(lo=0.0, hi=4.0), Arg(lo=0.0, hi=4.0, adversarial=(0.0,)),
                                 Arg(lo=0.0, hi=1.0)),
               atol=0.0, rtol=0.0, measured="exact (random inputs never sit on a threshold)",
               envelope="exact: compares of inputs with z_d (1 + 1e-4) and z_d + thickness, "
                        "each one correctly rounded op (x87 may keep it unrounded): a flip needs "
                        "z within 1 ulp of a threshold (p ~ 1e-3 over 4096 draws)"),
    ParityCase("ssao_upsample_weight", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0)),
                                        Arg(lo=-10.0, hi=10.0, components=3),
                                        Arg(kind="unit", components=3),
                                        Arg(lo=-1.0, hi=1.0, components=3),
                                        Arg(kind="unit", components=3)),
               atol=2e-5, rtol=1e-5, prepare=_upsample_geometry,
               measured="max abs 4.2e-7 on llvmpipe (seed 0)",
               envelope="1 - 50 |(p - q).n_q| / z_p: (p - q).n_q cancels, a few ulp of |p| <= "
                        "17 -> ~5e-6 abs, x 50 / z_p (>= 0.5) -> 2e-5 abs on a weight <= 1; "
                        "cos^8 amplifies the dot's ~3 ulp 8 x -> 1.4e-6 rel"),
]

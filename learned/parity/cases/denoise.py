"""Parity cases of ``shaders/lib/denoise.glsl`` against :mod:`learned.twins.denoise`."""
from __future__ import annotations

from .base import Arg, ParityCase

PARITY_CASES = [
    ParityCase("atrous_kernel", (Arg(kind="int", lo=-2, hi=2, adversarial=(0.0, -2.0, 2.0)),),
               atol=0.0, rtol=0.0, measured="exact", envelope="constants chosen by comparisons"),
    ParityCase("atrous_edge_weight",
               (Arg(lo=0.1, hi=20.0, adversarial=(0.0, 5.0)), Arg(lo=0.1, hi=20.0,
                                                                  adversarial=(0.0, 5.0)),
                Arg(kind="unit", components=3, adversarial=((0.0, 1.0, 0.0),)),
                Arg(kind="unit", components=3, adversarial=((0.0, 1.0, 0.0), (0.0, -1.0, 0.0))),
                Arg(lo=1.0, hi=16.0), Arg(lo=0.01, hi=0.2), Arg(lo=1.0, hi=256.0)),
               atol=2e-6, rtol=2e-5, measured="max abs 3.6e-7, max rel 4e-6 (seeds 0-3)",
               envelope="exp (3 + 2|x| ulp by GLSL, x <= ~100 where the weight is > 1e-40) "
                        "and pow (exp2 log2: 3 + 2|y log2 x| ulp, y <= 256, x near 1) give "
                        "~1e-5 rel at the largest arguments; the division 2.5 ulp"),
]

"""Parity cases of ``shaders/lib/common.glsl`` against :mod:`learned.twins.common`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

PARITY_CASES = [
    ParityCase("saturate", (Arg(lo=-2, hi=2, adversarial=(0.0, 1.0, -0.0, 1e30, -1e30)),),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: clamp returns the input, 0 or 1"),
    ParityCase("half_vector",
               (Arg(kind="unit", components=3, adversarial=((0, 0, 1),)),
                Arg(kind="unit", components=3, adversarial=((0, 0, -1), (0, 0, 1)))),
               atol=1e-6, rtol=1e-5, measured="max abs 1.8e-7, max rel 2.4e-7 (seeds 0-7)",
               envelope="v + l (1 rounding per component, relative to the sum), dot (5 ops), "
                        "inversesqrt 2 ulp, 3 products: ~8 ulp both sides -> 9e-7 of the unit "
                        "result; v = -l gives +Z exactly"),
    ParityCase("sq", (Arg(lo=-4, hi=4, adversarial=(0.0, 1e-20, 1e18)),),
               atol=1.2e-38, rtol=1e-7, measured="exact on llvmpipe; the H200 flushed "
                                                  "1e-20^2 = 1e-40 to 0",
               envelope="exact: one correctly rounded product (nothing to contract or reorder), "
                        "except a result below FLT_MIN (2^-126 = 1.18e-38): GLSL lets a GPU "
                        "flush denormals to zero, and NVIDIA's does"),
]

"""Parity cases of ``shaders/lib/ground.glsl`` against :mod:`learned.twins.ground`. Which pixels
are the catcher (``ground_catcher`` of passes/ground.glsl) is checked by rendering
(tests/viewer/test_ground.py)."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase

PASS_LEVEL = ()


def _ordered_radii(args):
    """r_start < r_end, as the pass passes them."""
    r, a, b = (np.array(x, np.float32, copy=True) for x in args)
    return [r, np.minimum(a, b), np.maximum(a, b) + 0.01]


PARITY_CASES = [
    ParityCase("ground_fade", (Arg(lo=0.0, hi=10.0, adversarial=(0.0, 2.0, 5.0)),
                               Arg(lo=0.0, hi=5.0, adversarial=(2.0,)),
                               Arg(lo=0.0, hi=10.0, adversarial=(5.0,))),
               atol=2e-6, rtol=0.0, measured="max abs 1.2e-7 on llvmpipe",
               envelope="smoothstep: a subtraction and a 2.5 ulp division (t in [0, 1] to "
                        "~3 ulp), t^2 (3 - 2t): ~6 ulp of values <= 1: 1e-6 abs",
               prepare=_ordered_radii),
    ParityCase("ground_catcher_radiance", (Arg(lo=0.0, hi=4.0, components=3),
                                           Arg(lo=0.0, hi=4.0, components=3,
                                               adversarial=((0.0, 0.0, 0.0),)),
                                           Arg(lo=0.0, hi=8.0, components=3),
                                           Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))),
               atol=1e-5, rtol=1e-5, measured="max abs 9.5e-7, max rel 2.9e-7 on llvmpipe",
               envelope="two 3-term dots (~4 ulp), a 2.5 ulp division, clamp, mix (2 roundings) "
                        "and a product with the background <= 8: ~10 ulp relative, 1e-5 rel"),
]

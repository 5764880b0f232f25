"""Parity cases of ``shaders/lib/shadow_net.glsl`` against :mod:`learned.twins.shadow_net`; the
feature-map fetch (a sampler) is covered by the ``shadow_net:layers`` pass check."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase

PASS_LEVEL = ("shadow_net_fetch",)


def _fine_pixel_inside(args):
    """x < 2 n: the fine pixels of a source n texels long."""
    x, n = args
    return [np.minimum(x, 2.0 * n - 1.0).astype(np.float32), n]


PARITY_CASES = [
    ParityCase("shadow_net_input_a",
               (Arg(lo=-1.0, hi=200.0, components=3, adversarial=((0.0, 0.0, 0.0),
                                                                    (-1.0, 1e-8, 6.0e4))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))),
               atol=1e-6, rtol=2e-6, measured="max abs 4.8e-7, max rel 2.1e-7 (seeds 0-3)",
               envelope="log: 3 ulp, or 2^-21 absolute where its argument is in [0.5, 2]"),
    ParityCase("shadow_net_demodulate",
               (Arg(lo=0.0, hi=200.0, components=3, adversarial=((0.0, 0.0, 0.0),
                                                                   (6.0e4, 1e-8, 1.0))),
                Arg(lo=0.0, hi=1.0, components=3, adversarial=((0.0, 0.05, 1.0),
                                                                (0.049, 0.051, 1e-8)))),
               atol=0.0, rtol=3e-7, measured="exact (seeds 0-3)",
               envelope="one division (2.5 ulp)"),
    ParityCase("shadow_net_input_b",
               (Arg(kind="unit", components=3),
                Arg(lo=-1.0, hi=100.0, adversarial=(0.0, -0.5, 1e-7, 1e6))),
               atol=0.0, rtol=3e-7, measured="exact (seeds 0-3)",
               envelope="one division (2.5 ulp)"),
    ParityCase("shadow_net_input_c", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0)),),
               atol=0.0, rtol=0.0, measured="exact", envelope="a copy"),
    ParityCase("shadow_net_act",
               (Arg(lo=-30.0, hi=30.0, components=4, adversarial=((0.0, -0.0, 88.0, -88.0),)),
                Arg(kind="int", lo=0, hi=1, adversarial=(0.0, 1.0))),
               atol=1e-7, rtol=5e-6, measured="max abs 1.2e-7, max rel 9.9e-7 (seeds 0-3)",
               envelope="exp: 3 + 2|x| ulp, |x| <= 30: 63 ulp = 3.8e-6 rel of exp, at most "
                        "that of 1 / (1 + exp); the division 2.5 ulp"),
    ParityCase("shadow_net_up_taps",
               (Arg(kind="int", lo=0, hi=400, adversarial=(0.0, 1.0, 2.0)),
                Arg(kind="int", lo=1, hi=200, adversarial=(1.0, 2.0))),
               atol=0.0, rtol=0.0, measured="exact", envelope="integers and constants",
               prepare=_fine_pixel_inside),
]

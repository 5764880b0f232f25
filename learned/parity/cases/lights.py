"""Parity cases of ``shaders/lib/lights.glsl`` against :mod:`learned.twins.lights`: the punctual
lights' range window, spot cone and direction/attenuation."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase


def _cone_order(index):
    """cone_range (argument ``index``): cos inner >= cos outer, and range <= 0 (none) for a
    quarter of the draws."""

    def fix(args):
        c = args[index]
        lo, hi = np.minimum(c[:, 0], c[:, 1]), np.maximum(c[:, 0], c[:, 1])
        c[:, 0], c[:, 1] = lo, hi
        c[::4, 2] = -1.0
        return args
    return fix


def _ordered_cos(args):
    lo, hi = np.minimum(args[1], args[2]), np.maximum(args[1], args[2])
    args[1], args[2] = lo, hi
    return args


PARITY_CASES = [
    ParityCase("light_range_window",
               (Arg(lo=0.0, hi=20.0, adversarial=(0.0, 5.0, 10.0)),
                Arg(lo=-2.0, hi=15.0, adversarial=(0.0, -1.0, 10.0))),
               atol=2e-6, rtol=1e-5, measured="exact on llvmpipe (seeds 0-3)",
               envelope="q = (d/range)^2 (one division at 2.5 ulp, one product), q^2, 1 - q^2 "
                         "cancels near d = range: ~6 x 2^-24 abs on values <= 1 before the "
                         "square -> ~1e-6 abs"),
    ParityCase("spot_cone_factor",
               (Arg(lo=-1.0, hi=1.0, adversarial=(1.0, 0.0, 0.5)), Arg(lo=0.0, hi=1.0),
                Arg(lo=0.0, hi=1.0)),
               atol=2e-6, rtol=1e-5, measured="exact on llvmpipe (seeds 0-3)", prepare=_ordered_cos,
               envelope="(c - c_o) / max(c_i - c_o, 1e-3): the subtractions are exact-ish "
                         "(Sterbenz) or 1 ulp, the division 2.5 ulp, the square 1 ulp on t <= 1; "
                         "t's slope 1/(c_i - c_o) times ~2 ulp of the cosines: ~1e-6 abs for "
                         "cosines drawn apart by >= ~0.25 (most draws); rtol for the rest"),
    ParityCase("punctual_light",
               (Arg(kind="int", lo=0, hi=2), Arg(lo=-3.0, hi=3.0, components=3),
                Arg(kind="unit", components=3), Arg(lo=0.0, hi=1.0, components=4),
                Arg(lo=-3.0, hi=3.0, components=3)),
               atol=1e-5, rtol=1e-4, prepare=_cone_order(3),
               measured="max abs 1.9e-6, max rel 2.1e-5 (seeds 0-3)",
               envelope="l = (x - p) / sqrt(d^2): 3 subtractions, a dot, sqrt (inversesqrt 2 ulp) "
                         "and a division: ~8 x 2^-24 rel per component; attenuation "
                         "window / d^2 and the spot factor (slope up to 1/(c_i - c_o) on a "
                         "dot of ~4 ulp): ~1e-5 rel for the drawn cones, atol for d -> 0 "
                         "attenuations clamped by the window"),
]

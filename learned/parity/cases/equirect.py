"""Parity cases of ``shaders/lib/equirect.glsl`` against :mod:`learned.twins.equirect`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

import math

from .base import Arg, ParityCase

PARITY_CASES = [
    ParityCase("equirect_uv",
               (Arg(kind="unit", components=3,
                    adversarial=((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0),
                                 (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (1e-20, 1.0, 0.0),
                                 (0.0, 2.0, 0.0), (3.0, 0.0, -4.0))),),
               atol=3e-6, rtol=1e-5,
               measured="max abs 1.07e-6 (seeds 0-7; llvmpipe's atan is 3.4e-6 rad off); the "
                        "H200 was 0.25 off at (1e-20, 1, 0) before the pole test moved to 1e-18",
               envelope="atan has no GLSL precision: assume 4e-6 rad (llvmpipe's polynomial "
                        "reaches 3.4e-6, GPU atan ~1e-6) -> theta / pi 1.3e-6, phi / 2pi 6e-7; "
                        "length(xz) (sqrt 4.5 ulp + dot) moves theta by <= 3e-7 -> 1.6e-6 abs"),
    ParityCase("equirect_dir",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (0.75, 0.5))),),
               atol=2.2e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7); nosse: 2.4e-7",
               envelope="sin/cos ~1e-6 abs each (assumed; |arg| <= pi): x = sin_t sin_p errs "
                        "1e-6 (|sin_p| + |sin_t|) <= 2e-6 where the argument roundings (~3e-7) "
                        "meet zero slope, + product rounding -> 2.1e-6 abs (atol widened from "
                        "1e-6)"),
    ParityCase("rotate_y",
               (Arg(lo=-2.0, hi=2.0, components=3, adversarial=((1.0, 0.0, 0.0),)),
                Arg(lo=-7.0, hi=7.0, adversarial=(0.0, math.pi / 2, -math.pi))),
               atol=5e-6, rtol=1e-5, measured="max abs 4.8e-7 (seeds 0-7; |angle| <= 7)",
               envelope="c v.x + s v.z with cos/sin ~1e-6 abs each (assumed, |angle| <= 7) times "
                        "|v.x| + |v.z| <= 4 -> 4e-6, + 3 roundings of terms <= 2.9 per side "
                        "(8e-7) -> 4.8e-6 abs (atol widened from 1e-6)"),
]

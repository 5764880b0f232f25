"""Parity cases of ``shaders/lib/shadow.glsl`` against :mod:`learned.twins.shadow`. The lookups
that read the map (``shadow_depth_at``, ``shadow_blocker_depth``, ``shadow_pcf``,
``shadow_visibility``) are the pass check ``shadow:lookups``."""
from __future__ import annotations

from .base import Arg, ParityCase

PASS_LEVEL = ("shadow_depth_at", "shadow_blocker_depth", "shadow_pcf", "shadow_visibility")

PARITY_CASES = [
    ParityCase("vogel_disk", (Arg(kind="int", lo=0, hi=63), Arg(kind="int", lo=1, hi=64),
                              Arg(lo=0.0, hi=6.2832)),
               atol=2e-5, rtol=0.0, measured="max abs 2e-6 on llvmpipe",
               envelope="sqrt of a quotient (3.5 ulp) times cos/sin of theta <= 160 rad: "
                        "trigonometry ~1e-6 absolute assumed, plus theta's own rounding "
                        "(160 x 2^-24 = 1e-5 rad) moving the point by <= 1e-5"),
    ParityCase("shadow_phi", (Arg(kind="int", lo=0, hi=4096, components=2),),
               atol=2e-4, rtol=0.0, measured="max abs ~1e-5 on llvmpipe",
               envelope="fract of 52.98 x fract(x 0.067 + y 0.0058) at pixel centres <= 4096: "
                        "the inner dot product's rounding (~2^-24 x 300) times 52.98 x 2 pi "
                        "-> 1e-4 abs, unless a fract wraps (p ~ 1e-4 per draw)"),
    ParityCase("shadow_depth_slope", (Arg(lo=-2.0, hi=2.0, components=3,
                                          adversarial=((0.0, 0.0, 1.0), (1.0, 0.5, 0.0),
                                                       (3.0, 4.0, 1.0))),),
               atol=1e-6, rtol=1e-5, measured="max abs 4.8e-7 on llvmpipe",
               envelope="-m.xy / m.z (2.5 ulp division) then a clamp to length 4 (a length: "
                        "sqrt ~3 ulp, a 4 / len division): 6 roundings on values <= 4"),
    ParityCase("shadow_receiver", (Arg(lo=-10.0, hi=10.0, components=3),
                                   Arg(kind="unit", components=3), Arg(kind="unit", components=3),
                                   Arg(lo=1e-4, hi=0.1)),
               atol=1e-6, rtol=1e-6, measured="exact on llvmpipe",
               envelope="p + n t (1.5 + 3 (1 - NoL)): a dot product and 4 roundings on "
                        "|p| <= 17: 5 ulp rel of p"),
]

"""Parity cases of ``shaders/lib/path.glsl`` against :mod:`learned.twins.path`."""
from __future__ import annotations

from .base import Arg, ParityCase

PARITY_CASES = [
    ParityCase("sample_uniform_cone",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.9999999, 0.5), (0.5, 0.9999999))),
                Arg(lo=-1.0, hi=1.0, adversarial=(1.0, 0.99995728, -1.0, 0.0))),
               atol=3e-6, rtol=1e-5, measured="max abs 4.8e-7 (seeds 0-3)",
               envelope="cos/sin ~1e-6 abs (assumed) times sin_t <= 1, the phi product's "
                         "rounding, sqrt 3 ulp of 1 - cos^2 (cancellation near the axis: "
                         "|d sin| <= 1e-7 / sin ~ 3e-4 at sin 3e-4 is below the random inputs' "
                         "floor) -> 2e-6 abs"),
    ParityCase("pdf_uniform_cone",
               (Arg(lo=-1.0, hi=0.9999, adversarial=(1.0, 0.99995728, -1.0)),),
               atol=0.0, rtol=2e-6, measured="max rel 1.2e-7",
               envelope="one product and one 2.5-ulp division of 2 pi (1 - c): 4 ulp = 5e-7 "
                        "rel, doubled where 1 - c loses bits near 1 (exact by Sterbenz)"),
    ParityCase("path_continue_probability",
               (Arg(lo=0.0, hi=1.5, components=3, adversarial=((0.0, 0.0, 0.0), (2.0, 0.5, 0.1))),
                Arg(kind="int", lo=0, hi=8, adversarial=(2.0, 3.0))),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="max and clamp are exact"),
]

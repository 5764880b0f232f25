"""Parity cases of ``shaders/lib/sh.glsl`` against :mod:`learned.twins.sh`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

# sh_irradiance takes a vec3[9] array: covered by the "sh_irradiance" pass check in twins/ibl.py.
PASS_LEVEL = ("sh_irradiance",)


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("sh_basis", (Arg(kind="int", lo=-1, hi=9,
                                adversarial=tuple(float(i) for i in range(9))),
                            Arg(kind="unit", components=3,
                                adversarial=((0.0, 1.0, 0.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0)))),
               atol=1e-7, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7); nosse: 1.2e-7",
               envelope="constant x <= 2 component products: <= 3 roundings per side -> 3.6e-7 "
                        "rel; 3 z^2 - 1 and x^2 - y^2 cancel: ulps of terms <= 1 (~1.2e-7) x "
                        "0.32 / 0.55 per side -> 7.6e-8 abs (first-order uses 75%)"),
    ParityCase("sh_cosine_lobe", (Arg(kind="int", lo=0, hi=8),), atol=0.0, rtol=1e-7,
               measured="exact",
               envelope="exact: pi, 2 pi / 3 (folding in float32 or in double gives the same "
                        "float) and pi / 4 (power-of-2 scale)"),
]

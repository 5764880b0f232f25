"""Parity cases of ``shaders/lib/env_sampling.glsl`` against :mod:`learned.twins.env_sampling`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

# Functions taking samplers, covered by the pass check "env_sampling" below.
PASS_LEVEL = ("cdf_find", "sample_env", "env_pdf")


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("luminance", (Arg(lo=0.0, hi=100.0, components=3, adversarial=((0, 0, 0),)),),
               atol=1e-6, rtol=1e-6, measured="max rel 1.9e-7 (seeds 0-7)",
               envelope="dot with the BT.709 weights (same float32 literals): 3 products + 2 adds "
                        "of terms >= 0 in any order, 5 roundings per side -> 3.6e-7 rel"),
    ParityCase("env_pdf_solid_angle", (Arg(lo=0.0, hi=1000.0, adversarial=(0.0,)),
                                       Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-7, 1.0))),
               atol=0.0, rtol=1e-6, measured="max rel 2.5e-7 (seeds 0-7)",
               envelope="2 pi^2 folded in float32 by GLSL, rounded once by torch (<= 1 ulp), "
                        "x sin_theta, / (2.5 ulp + 0.5): ~5 ulp -> 6e-7 rel; sin_theta > 0 "
                        "compares the input"),
    ParityCase("env_row_sin_theta", (Arg(kind="int", lo=0, hi=1023, adversarial=(0.0, 511.0)),
                                     Arg(kind="int", lo=1024, hi=1024, adversarial=(1.0, 512.0))),
               atol=2.6e-6, rtol=1e-6, measured="max abs 6e-8 (seeds 0-7)",
               envelope="arg = pi (row + 0.5) / h <= pi: product + division (2.5 ulp) + "
                        "torch's 2 roundings = 8 x 2^-24 rel -> 1.5e-6 abs in arg (x |cos| <= 1); "
                        "sin ~1e-6 abs assumed (no GLSL precision) -> 2.6e-6 (atol widened from "
                        "1e-6); (511, 1) is sin(511.5 pi), an extremum: first-order blind to "
                        "float32 reduction"),
]

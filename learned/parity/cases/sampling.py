"""Parity cases of ``shaders/lib/sampling.glsl`` against :mod:`learned.twins.sampling`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_UINT = Arg(kind="int", lo=0, hi=(1 << 24) - 1, adversarial=(0.0, 1.0, 2.0, 3.0, 255.0, 16777215.0))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("radical_inverse_vdc", (_UINT,), atol=0.0, rtol=0.0, measured="bit-exact",
               envelope="exact: integer bit reversal, 24-bit value converts exactly, x 2^-24 "
                        "exact"),
    ParityCase("hammersley", (Arg(kind="int", lo=0, hi=4095, adversarial=(0.0, 63.0, 4095.0)),
                              Arg(kind="int", lo=1, hi=4096, adversarial=(0.0, 1.0, 64.0, 4096.0))),
               atol=0.0, rtol=3.6e-7, measured="bit-exact on llvmpipe",
               envelope="radical inverse exact; float(i) / float(n): GLSL division 2.5 ulp "
                        "(GPUs use a * rcp(b)) + torch's 0.5 -> 3 ulp = 3.6e-7 rel (rtol widened "
                        "from 0)"),
    ParityCase("importance_sample_ggx",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.999, 0.9999999), (0.5, 1.0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 1.0))),
               atol=2e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7; sin/cos of phi)",
               envelope="sin_theta (cos, sin) phi: trig ~1e-6 abs (assumed) + 2 pi xi.x rounding "
                        "2.4e-7 + sin2 = a2 t / denom (2.5 ulp) and sqrt (4.5 ulp) -> 2e-6 abs "
                        "(first-order on the draws 1.7e-6; atol widened from 1e-6); z = "
                        "sqrt(cos2) ~8 ulp rel"),
    ParityCase("ggx_sample_d",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.999, 0.9999999), (0.5, 1.0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 0.0625, 1.0))),
               atol=0.0, rtol=1.2e-6, measured="max rel 1.2e-7 (seeds 0-7); nosse: 4.1e-7",
               envelope="q = (1 - t) + a2 t sums terms >= 0 (2 roundings), q q (5), a2 (1), "
                        "pi a2 (1), / 2.5 ulp (5) in units of 2^-24: 12 GPU + 8 torch = 1.2e-6 "
                        "rel (rtol widened from 1e-6)"),
    ParityCase("tangent_to_world",
               (Arg(kind="unit", components=3, adversarial=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))),
                Arg(kind="unit", components=3,
                    adversarial=((0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0),
                                 (0.0, 0.99999994, -0.0003452669)))),
               atol=1e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="Duff et al. basis: a = -1 / (s + n.z) with |s + n.z| >= 1 (2.5 ulp), "
                        "entries ~4 roundings, 3-term combination with |v| = 1 (cancels): "
                        "first-order 7e-7 abs near 0, 70% of the tolerance"),
]

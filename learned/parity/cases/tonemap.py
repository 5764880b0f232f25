"""Parity cases of ``shaders/lib/tonemap.glsl`` against :mod:`learned.twins.tonemap`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_HDR = Arg(lo=0.0, hi=20.0, components=3,
           adversarial=((0, 0, 0), (1e-8, 1e-8, 1e-8), (65504, 1, 0), (1e5, 1e5, 1e5),
                        (-1, 0.5, 2)))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("apply_exposure", (_HDR, Arg(lo=-8, hi=8, adversarial=(0.0, -40.0, 40.0))),
               atol=1e-6, rtol=1.1e-5, measured="max rel 3.5e-7 (seeds 0-7)",
               envelope="exp2 (3 + 2|ev|) ulp: 83 ulp = 9.9e-6 at the adversarial ev = +-40 "
                        "(19 ulp = 2.3e-6 for |ev| <= 8) + product and torch's exp2 1 ulp -> "
                        "1.05e-5 rel (rtol widened from 2e-6)"),
    ParityCase("rrt_odt_fit", (Arg(lo=0.0, hi=50.0, components=3, adversarial=((0, 0, 0),)),),
               atol=1e-6, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7); nosse: 2.4e-7",
               envelope="a / b: a = v (v + 0.0246) - 9.05e-5 cancels near v = 3.6e-3 (ulps of "
                        "terms <= 1e-4 over b >= 0.238), b sums terms >= 0, / 2.5 ulp: "
                        "first-order 1.2e-6 rel, 11% of the tolerance"),
    ParityCase("tonemap_aces_fitted", (_HDR,), atol=2e-6, rtol=1e-5,
               measured="max abs 4.2e-7 (seeds 0-7)",
               envelope="input matrix (terms >= 0), rrt_odt_fit, output matrix with negative "
                        "entries (cancels, any order/FMA), clamp: first-order uses 41% of the "
                        "tolerance"),
    ParityCase("tonemap_reinhard", (_HDR,), atol=1e-7, rtol=1e-6, measured="exact",
               envelope="x / (1 + x): add + division (2.5 ulp) + torch's 2 roundings -> 4 ulp "
                        "= 4.8e-7 rel"),
    ParityCase("linear_to_srgb", (Arg(lo=0.0, hi=1.2, components=3,
                                      adversarial=((0, 0.0031308, 1), (-1, 2, 0.5))),),
               atol=2e-6, rtol=1e-5, measured="max abs 2.4e-7, rel 7.2e-7 (pow; seeds 0-7)",
               envelope="pow = exp2(log2(x) / 2.4): log2 2^-21 abs in [0.5, 1] or 3 ulp, exp2 "
                        "3 ulp, then 1.055 p - 0.055 cancels (x2.4 at the knee): first-order "
                        "5.8e-6 rel, 11% of the tolerance; the knee compare uses the input"),
    ParityCase("srgb_to_linear", (Arg(lo=0.0, hi=1.0, components=3,
                                      adversarial=((0, 0.04045, 1),)),),
               atol=2e-6, rtol=1e-5, measured="max abs 3.6e-7, rel 6.8e-7 (pow; seeds 0-7)",
               envelope="q = (x + 0.055) / 1.055 (2.5 ulp, x2.4 through the power), pow = "
                        "exp2(2.4 log2 q): log2 2^-21 abs in [0.5, 1] else 3 ulp (|log2 q| <= "
                        "4.2) x 2.4 ln 2, exp2 3 ulp: first-order 6e-6 rel, 20% of the tolerance"),
]

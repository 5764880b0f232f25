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
    ParityCase("tonemap_pbr_neutral", (Arg(lo=0.0, hi=20.0, components=3,
                                           adversarial=((0, 0, 0), (0.08, 0.5, 0.9),
                                                        (0.76, 0.2, 0.1), (1e5, 1e5, 1e5),
                                                        (2e6, 0.5, 0), (-1, 0.5, 2))),),
               atol=2e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="offset f = m - m^2 / 0.16 (3 roundings), the compression p_n = 1 - "
                        "d^2 / (p + d - k_s) (division 2.5 ulp) and g = 1 / (k_d (p - p_n) + 1): "
                        "p - p_n cancels near the knee (p ~ 0.76: ulps of p over a difference "
                        "~1e-3, x k_d), each output a convex mix of values in [0, 1]: first-order "
                        "~6 ulp = 4e-7 abs; the knee compares p with k_s and m with 0.08, so a "
                        "draw within 1 ulp of either could flip a branch (continuous there)"),
    ParityCase("agx_contrast", (Arg(lo=0.0, hi=1.0, components=3,
                                    adversarial=((0, 0.5, 1),)),),
               atol=2e-5, rtol=0.0,
               measured="max abs 1.3e-6 (rel 5e-5 beside the root near x = 0.02; seeds 0-7)",
               envelope="a degree-6 polynomial with coefficients up to 40 summed with "
                        "cancellation (terms ~30, result ~0.5 at x = 1): 7 terms x 2^-24 x 40 = "
                        "1.7e-5 worst abs in any evaluation order; x in [0, 1] keeps terms "
                        "<= 40: first-order on the draws 1.2e-6 abs"),
    ParityCase("tonemap_agx", (_HDR,), atol=9e-5, rtol=1e-5,
               measured="max abs 4.0e-5 (seeds 0-7)",
               envelope="inset matrix (terms >= 0), log2 (2^-21 abs in [0.5, 2] else 3 ulp) over "
                        "16.5 EV -> 1.5e-7 abs in [0, 1], agx_contrast's polynomial (slope <= 2.4 "
                        "-> 4e-7), outset matrix with negative entries, pow 2.2 (exp2 3 ulp, log2 "
                        "as above: 2.2 x 2^-21 x ln2 rel), Rec. 2020 -> 709 cancels: the "
                        "polynomial's worst 1.7e-5 abs x pow's slope 2.2 x the matrix's row sum "
                        "2.32 -> 8.7e-5 (float32 itself: the twin in float32 is 3.0e-5 from "
                        "float64 at (14.9, 17.0, 2.8))"),
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

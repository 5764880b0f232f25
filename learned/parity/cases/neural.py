"""Parity cases of ``shaders/lib/neural.glsl`` against :mod:`learned.twins.neural`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

import math

from .base import Arg, ParityCase
from .shading import _ALPHA_L, _UNIT, _UP, _fix_dfg_at, _nonneg3

PASS_LEVEL = ()

# spec_scale of the split3 functions: 1 (single scattering) or the multiple-scattering
# compensation 1 + f0 (1 / dfg.y - 1), 1 to ~1.6 over the DFG LUT; drawn up to 2
_SPEC_SCALE = Arg(lo=1.0, hi=2.0, components=3, adversarial=((1.0, 1.0, 1.0), (1.0, 1.6, 2.0)))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    # sin/cos of |freq x| up to 32 pi ~ 100 rad: the argument's float32 reduction dominates
    ParityCase("fourier_feature", (Arg(lo=-1.0, hi=1.0, adversarial=(0.0, 1.0, -1.0)),
                                   Arg(lo=0.0, hi=32 * math.pi,
                                       adversarial=(math.pi, 2 * math.pi, 16 * math.pi))),
               atol=1.7e-5, rtol=0.0,
               measured="max abs 6e-8 (seeds 0-7); nosse (x87, a kept unrounded): 3.8e-6",
               envelope="a = freq x, |a| <= 100.5: sin/cos ~1e-6 abs (assumed) + GPUs reduce "
                        "a / 2pi in float32, |a| 2^-23 = 1.2e-5 + a's own rounding, skipped by "
                        "x87: 0.5 ulp(a) = 3.8e-6 -> 1.7e-5 abs (atol widened from 2e-6)"),
    ParityCase("relu4",
               (Arg(lo=-5.0, hi=5.0, components=4, adversarial=((0, -0.0, 1e30, -1e30),)),),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: max selects the input or 0"),
    ParityCase("sigmoid4", (Arg(lo=-20.0, hi=20.0, components=4,
                                adversarial=((0, 80, -80, 1e-7),)),),
               atol=1e-7, rtol=1e-6, measured="max abs 1.2e-7, max rel 9.9e-7 (seeds 0-7)",
               envelope="1 / (1 + exp(-x)): exp (3 + 2|x|) ulp times s (1 - s) <= 1.2e-7 abs "
                        "(|x| ~ 1), 1 + e and / (2.5 ulp) -> 4 ulp rel: first-order uses 75% "
                        "of the tolerance"),
    ParityCase("softplus4", (Arg(lo=-20.0, hi=20.0, components=4,
                                 adversarial=((0, 80, -80, 1e-7),)),),
               atol=8e-7, rtol=1e-6,
               measured="max abs 9.5e-7 at x = 20 (rel 5e-8), values below 1e-7 within 1e-7 "
                        "(seeds 0-7)",
               envelope="log(u), u = 1 + e^-|x| in [1, 2]: GLSL allows 2^-21 abs, times "
                        "y / (u - 1) <= 1.5 -> 7.2e-7 abs where the result ~ y (atol widened "
                        "from 1e-7); exp (3 + 2|x|) ulp rel of y; large x: x + l1p, 2 ulp rel"),
    ParityCase("neural_student_radiance",
               (Arg(components=3), Arg(components=3), Arg(components=3),
                Arg(lo=0.0, hi=50.0, components=3), Arg(lo=0.0, hi=50.0, components=3,
                                                        adversarial=((0, 0, 0), (2000, 1, 0)))),
               atol=1e-6, rtol=1e-6, measured="max rel 2.3e-7 (max abs 7.6e-6 at ~2000)",
               envelope="S k_d albedo E / pi + S k_s P: 5 products (S = 2 exact) + 1 add of "
                        "terms >= 0 per side -> 4.8e-7 rel"),
    ParityCase("neural_student_radiance_pbr",
               (Arg(components=3), Arg(components=3), Arg(components=3), Arg(),
                Arg(lo=0.0, hi=50.0, components=3), Arg(lo=0.0, hi=50.0, components=3,
                                                        adversarial=((0, 0, 0), (2000, 1, 0)))),
               atol=1e-6, rtol=1e-6, measured="max rel 2.0e-7 (max abs 1.5e-5 at ~2000)",
               envelope="s_d diffuse E / pi + (s_a f0 + s_b f90) P: 6 products + 2 adds of "
                        "terms >= 0 per side -> 4.8e-7 rel"),
    ParityCase("neural_student_radiance_split",
               (Arg(components=3), Arg(components=3), Arg(components=3), Arg(),
                Arg(components=2, adversarial=((0, 0), (1, 1), (0.3, 0.3))),
                Arg(lo=0.0, hi=50.0, components=3), Arg(lo=0.0, hi=50.0, components=3,
                                                        adversarial=((0, 0, 0), (2000, 1, 0))),
                _SPEC_SCALE),
               atol=2e-5, rtol=1e-6, measured="max abs 3.8e-6 (seed 0)",
               envelope="terms to 2 x 50 / pi x 1 ~ 32 (diffuse) and 2 x 2000 x 2 (specular at "
                        "the adversarial P, m <= 2): the differences dfg.y - dfg.x and "
                        "1 - e_spec m cancel, so their rounding (u on values <= 2) is absolute: "
                        "4 u x 32 = 7.6e-6 on the diffuse term; products and the add 5.4e-7 rel"),
    # ggx_environment_sun's body with the student's corrections
    ParityCase("neural_student_sun_split",
               (Arg(components=3, adversarial=((0.5, 0.5, 0.5), (0, 1, 0))), _nonneg3(),
                _nonneg3(), Arg(), Arg(lo=0.0, hi=1.0, components=2), _ALPHA_L, _UNIT, _UP,
                _UNIT, _nonneg3(10.0, ((1e5, 0, 65504),)), Arg(lo=0.0, hi=1.0), _SPEC_SCALE),
               atol=1e-6, rtol=3.5e-3, prepare=_fix_dfg_at(4),
               measured="max rel 2.5e-5 (seeds 0-3; ggx_environment_sun 7.0e-5)",
               envelope="as ggx_environment_sun: D_GGX's sensitivity to n.h at small alpha; "
                        "the corrections S k and the compensation m add one rounding per term "
                        "(S = 2 exact)"),
    ParityCase("neural_indirect_factor", (Arg(adversarial=(0.0, 0.5, 1.0)),),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: S k with S = 2, a power of two"),
]

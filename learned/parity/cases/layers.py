"""Parity cases of ``shaders/lib/layers.glsl`` against :mod:`learned.twins.layers`: input domains,
adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_DOT = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 1e-7, -0.5, 1.5))
_UNIT = Arg(kind="unit", components=3, adversarial=((0, 0, 1), (0, 0, -1), (1, 0, 0),
                                                     (0.6, 0, -0.8)))

PARITY_CASES = [
    ParityCase("clearcoat_weight", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 2.0)), _DOT),
               atol=1e-7, rtol=1e-6, measured="max abs 1.2e-7, rel 3.1e-7 (seeds 0-7)",
               envelope="x^5 by products (5 roundings) and one multiply-add, c times: ~8 "
                        "roundings of terms >= 0 -> 5e-7 rel"),
    ParityCase("clearcoat_split_sum",
               (Arg(lo=0.0, hi=1.0), Arg(lo=0.0, hi=1.0, components=2),
                Arg(lo=0.0, hi=100.0, components=3, adversarial=((1e5, 0, 65504),))),
               atol=0.0, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="two products of terms >= 0 in either order: 2 roundings per side "
                        "-> 2.4e-7 rel"),
    ParityCase("clearcoat_light",
               (Arg(lo=0.0, hi=1.0), Arg(lo=0.0, hi=1.0, adversarial=(0.002025, 1.0)), _UNIT,
                Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1),)), _UNIT),
               atol=1e-6, rtol=3.5e-3, measured="max rel 6.4e-5 (seeds 0-7): D_GGX at small alpha, as ggx_directional_light",
               envelope="as ggx_directional_light (lib/shading.glsl): D_GGX's sensitivity to "
                        "1-ulp differences in n.h at small alpha, first-order 3.5e-3 rel"),
    ParityCase("oct_encode", (_UNIT,), atol=2e-7, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="|x| + |y| + |z| (2 adds) and a division (2.5 ulp), the fold 1 - |p|: "
                        "~5 roundings of values <= 1 -> 3e-7 abs"),
    ParityCase("oct_decode", (Arg(lo=-1.0, hi=1.0, components=2,
                                  adversarial=((0, 0), (1, 0), (0.5, -0.5), (-1, -1))),),
               atol=1e-6, rtol=1e-6, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="1 - |x| - |y| (2 roundings), the fold, normalize (inversesqrt 2 ulp, "
                        "a dot): ~8 roundings of values <= 1 -> 5e-7 abs"),
]

_SHEEN_A = Arg(lo=0.0049, hi=1.0, adversarial=(0.0049, 1.0))  # alpha = r^2, r in [0.07, 1]
_COLOR = Arg(lo=0.0, hi=1.0, components=3, adversarial=((0, 0, 0), (1, 1, 1)))

PARITY_CASES += [
    ParityCase("d_charlie", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.5, 1.0)), _SHEEN_A),
               atol=1e-6, rtol=2e-4, measured="max rel 8.4e-6 (abs 1.2e-4 on values up to 33; seeds 0-7)",
               envelope="pow(sin^2, 1/(2a)) = exp2(y log2 x) with y up to 102: log2's 3 ulp "
                        "times y plus exp2's 3 + 2|x| ulp, and 1 - NoH^2's rounding times y "
                        "-> ~1e-4 rel at a = 0.0049"),
    ParityCase("sheen_lambda_fit", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.5, 1.0)), _SHEEN_A),
               atol=2e-5, rtol=2e-6, measured="max abs 3.3e-6 (seeds 0-7)",
               envelope="pow (exp2 log2) and a division of values up to 25, four mixes: "
                        "~10 roundings of terms up to 25 -> 1e-5 abs"),
    ParityCase("sheen_lambda", (Arg(lo=-1.0, hi=1.0, adversarial=(0.0, 0.5, -0.5, 1.0)),
                                _SHEEN_A),
               atol=1e-7, rtol=1e-4, measured="max rel 4.5e-6 (seeds 0-7)",
               envelope="exp of sheen_lambda_fit (up to 17): its 1e-5 abs error becomes "
                        "1e-5 rel, exp's 3 + 2|x| ulp adds 4e-6 -> 1e-4 rel bound"),
    ParityCase("v_charlie", (_DOT, _DOT, _SHEEN_A),
               atol=1e-7, rtol=2e-4, measured="max rel 3.3e-6 (seeds 0-7)",
               envelope="1 / ((1 + L_v + L_l) 4 n.v n.l): the two Lambdas' 1e-4 rel and a "
                        "division (2.5 ulp) -> 2e-4 rel"),
    ParityCase("sheen_albedo", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 1e-7, -0.5, 1.5)),
                                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.07, 1.0, 1.5))),
               atol=1e-6, rtol=1e-6, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="sqrt and two scalings to the cell (a 1-ulp move across a cell edge "
                        "changes the bilinear value continuously), three mixes of table values "
                        "<= 1: ~8 roundings -> 5e-7 abs"),
    ParityCase("sheen_normalization", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.07, 0.19, 1.0,
                                                                        1.5)),),
               atol=1e-6, rtol=1e-6, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="two scalings to the sample and one mix of values <= 1.7: ~4 "
                        "roundings -> 4e-7 abs"),
    ParityCase("sheen_scaling", (_COLOR, _DOT, _DOT), atol=1e-7, rtol=1e-6,
               measured="exact on llvmpipe (seeds 0-7)", envelope="max3, a max, one multiply-add: 2 roundings of "
                                        "values <= 1 -> 1.2e-7 abs"),
    ParityCase("sheen_split_sum", (_COLOR, _DOT, Arg(lo=0.0, hi=100.0, components=3)),
               atol=0.0, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="two products of terms >= 0: 2 roundings -> 2.4e-7 rel"),
    ParityCase("sheen_light", (_COLOR, Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.07, 1.0)), _UNIT,
                               Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1),)),
                               _UNIT),
               atol=1e-6, rtol=1e-3, measured="max rel 7.5e-5 (seeds 0-7)",
               envelope="d_charlie's 2e-4 rel and its sensitivity to n.h (1-ulp differences "
                         "in the half vector times the exponent 1/(2a) up to 102: ~1e-5 rel per "
                         "ulp of n.h), v_charlie's 2e-4 -> 1e-3 rel"),
]

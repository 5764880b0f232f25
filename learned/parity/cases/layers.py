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

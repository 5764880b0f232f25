"""Parity cases of ``shaders/lib/transmission.glsl`` against :mod:`learned.twins.transmission`:
input domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_ALPHA = Arg(lo=0.0, hi=1.0, adversarial=(0.002025, 0.25, 1.0))
_UNIT = Arg(kind="unit", components=3, adversarial=((0, 0, 1), (0, 0, -1), (0.6, 0, -0.8)))
_UP = Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1), (0.6, 0, 0.8)))
_ETA = Arg(lo=0.5, hi=2.5, adversarial=(1.5, 1.0 / 1.5, 1.0))

PARITY_CASES = [
    ParityCase("mirror_through", (_UNIT, _UNIT), atol=5e-7, rtol=1e-6,
               measured="max abs 2.4e-7 (seeds 0-7)",
               envelope="a dot (3 roundings) and a multiply-add per component of values <= 3: "
                        "~5 roundings -> 4e-7 abs"),
    ParityCase("thin_transmission_cos", (_ALPHA, _UP, _UP, _UNIT), atol=1e-6, rtol=3.5e-3,
               measured="max rel 5.7e-5 (seeds 0-7)",
               envelope="as clearcoat_light (lib/layers.glsl): D_GGX's sensitivity to 1-ulp "
                        "differences in n.h at small alpha, first-order 3.5e-3 rel"),
    ParityCase("refraction_half_vector", (_UP, _UP, _UNIT, _ETA), atol=2e-6, rtol=1e-5,
               measured="max abs 1.8e-7 (seeds 0-7)",
               envelope="v + eta l (1 rounding), inversesqrt (2 ulp) of a dot: ~6 roundings "
                        "of unit values -> 7e-7 abs; where |v + eta l| is small the "
                        "direction's error grows as 1 / |v + eta l| (>= 1e-6: 2e-6 abs kept)"),
    ParityCase("rough_refraction_cos", (_ALPHA, _ETA, _UP, _UP, _UNIT), atol=1e-6, rtol=5e-3,
               measured="max rel 4.1e-5 (seeds 0-7)",
               envelope="D_GGX at small alpha as thin_transmission_cos (3.5e-3 rel) and the "
                        "Jacobian's 1 / (v.h + eta l.h)^2, a difference of terms of opposite "
                        "signs: 5e-3 rel"),
    ParityCase("rough_refraction_pdf", (_ALPHA, _ETA, _UP, _UP, _UNIT), atol=1e-6, rtol=5e-3,
               measured="max rel 4.1e-5 (seeds 0-7)",
               envelope="as rough_refraction_cos"),
    ParityCase("volume_attenuation",
               (Arg(lo=0.0, hi=10.0, components=3, adversarial=((0, 0, 0), (1e3, 1, 0.01))),
                Arg(lo=0.0, hi=5.0, adversarial=(0.0, -1.0, 100.0))),
               atol=1e-7, rtol=4e-6, measured="max abs 1.8e-7, rel 2.1e-6 (seeds 0-7)",
               envelope="one product and exp (GLSL exp: 3 ulp of its argument's size, here "
                        "<= 1e5 so 2e-6 rel after the product's rounding)"),
    ParityCase("dispersive_refraction_cos",
               (_ALPHA, Arg(lo=0.5, hi=2.5, components=3,
                            adversarial=((1.125, 1.5, 1.875), (1.5, 1.5, 1.5),
                                         (0.8, 2.0 / 3.0, 0.55))), _UP, _UP, _UNIT),
               atol=1e-6, rtol=5e-3,
               measured="max rel 1.6e-4 (seeds 0-7; max abs 3.7e-3 on large near-peak values)",
               envelope="rough_refraction_cos per channel (5e-3 rel)"),
    ParityCase("dispersive_refraction_pdf",
               (_ALPHA, Arg(lo=0.5, hi=2.5, components=3,
                            adversarial=((1.125, 1.5, 1.875), (1.5, 1.5, 1.5))),
                Arg(lo=0.0, hi=1.0, components=3, adversarial=((1 / 3, 1 / 3, 1 / 3), (1, 0, 0))),
                _UP, _UP, _UNIT),
               atol=1e-6, rtol=5e-3,
               measured="max rel 4.0e-5 (seeds 0-7; max abs 0.25 on large near-peak values)",
               envelope="rough_refraction_pdf per channel (5e-3 rel), weighted by w in a dot: "
                        "3 roundings more"),
    ParityCase("draw_channel",
               (Arg(lo=0.0, hi=1.0, components=3,
                    adversarial=((1 / 3, 1 / 3, 1 / 3), (1, 0, 0), (0, 0.5, 0.5), (0.5, 0.5, 0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.5, 0.99999994))),
               atol=1e-5, rtol=1e-5, measured="exact (seeds 0-7)",
               envelope="a difference and a quotient of values <= 1 (~2 roundings); a u within "
                        "rounding of a share's edge could pick the neighbour channel on one "
                        "side only: random inputs meet none"),
    ParityCase("dispersion_iors",
               (Arg(lo=1.0, hi=2.5, adversarial=(0.0, 1.0, 1.5)),
                Arg(lo=0.0, hi=40.0, adversarial=(0.0, 20.0, 1e4))),
               atol=1e-6, rtol=1e-6, measured="exact (seeds 0-7)",
               envelope="two products, a difference and a sum or difference of values <= 2.5 "
                        "(dispersion <= 40; the adversarial 1e4's larger values round "
                        "relatively too): ~4 roundings, 5e-7 rel"),
    ParityCase("volume_exit_offset",
               (_UP, _UP, Arg(lo=0.0, hi=2.0, adversarial=(0.0, 0.8)),
                Arg(lo=1.0, hi=2.5, adversarial=(0.0, 1.0, 1.5, 0.7))),
               atol=2e-6, rtol=1e-5,
               measured="max abs 3.6e-7 (seeds 0-7; rel 6.4e-4 on components near 0)",
               envelope="refract: a dot, k = 1 - eta^2 (1 - (n.i)^2) and sqrt(k) (~6 roundings "
                        "of unit values), then a normalisation (inversesqrt, 2 ulp) times a "
                        "thickness <= 2: ~1e-6 abs. IORs >= 1 (glTF's range, entering from "
                        "outside: k >= 1 - eta^2, no total internal reflection); near k = 0 "
                        "(an IOR < 1 at grazing angles) sqrt(k) amplifies k's rounding (4e-3 "
                        "rel measured over [0, 2.5]), so only the adversarial 0.7 goes there"),
    ParityCase("transmission_lod",
               (_ALPHA, Arg(lo=0.0, hi=2.5, adversarial=(0.0, 1.0, 1.25, 1.5)),
                Arg(lo=0.0, hi=12.0, adversarial=(0.0, 6.0))),
               atol=1e-6, rtol=1e-6, measured="exact (seeds 0-7)",
               envelope="at most 3 correctly rounded operations on values <= 12: 4e-7 rel"),
    ParityCase("transmission_irradiance",
               (Arg(lo=0.0, hi=10.0, components=3, adversarial=((0, 0, 0), (1e3, 1, 0.01))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 1.5)),
                Arg(lo=0.0, hi=10.0, components=3, adversarial=((0, 0, 0), (1e3, 1, 0.01)))),
               atol=1e-6, rtol=4e-6,
               measured="max abs 3.8e-6 (of values to 1e3), rel 2.1e-6 (seeds 0-7)",
               envelope="mix (x (1 - a) + y a; llvmpipe may fuse it as x + a (y - x), whose "
                        "difference rounds relative to the larger input: a result smaller "
                        "than its inputs keeps ~1 ulp of the larger, 2e-6 rel measured) and "
                        "pi y: ~5 roundings"),
]

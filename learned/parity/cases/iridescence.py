"""Parity cases of ``shaders/lib/iridescence.glsl`` against :mod:`learned.twins.iridescence`:
input domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_COS = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 1e-4, -0.5))
_F0 = Arg(lo=0.0, hi=1.0, components=3, adversarial=((0, 0, 0), (0.04, 0.04, 0.04),
                                                     (0.95, 0.64, 0.54), (1, 1, 1)))
_IOR = Arg(lo=1.0, hi=2.5, adversarial=(1.0, 1.3, 2.333))
_NM = Arg(lo=0.0, hi=1200.0, adversarial=(0.0, 15.0, 400.0, 1200.0))
_FILM = Arg(lo=0.0, hi=1.0, components=3)  # (factor, thickness nm, IOR), drawn then mapped
_OUTSIDE = Arg(lo=1.0, hi=1.5, adversarial=(1.0, 1.5))  # air .. under a full clearcoat


def _film(args):
    """Map the film argument (the one before the last, the outside IOR) from [0, 1]^3 to
    (factor, thickness in [0, 1200] nm, IOR in [1, 2.5]), a third of the rows with factor 0 or
    thickness 0."""
    film = args[-2].copy()
    film[:, 1] *= 1200.0
    film[:, 2] = 1.0 + 1.5 * film[:, 2]
    film[::6, 0] = 0.0
    film[1::6, 1] = 0.0
    return [*args[:-2], film, args[-1]]


# the interference terms: cos(pos phase + shift) with pos phase up to 2.2e6 x 2 pi x 4.8e-6 ~ 67
# rad: the argument's float32 rounding (ulp 7.6e-6 at 67, times the sensitivity's amplitude ~1,
# times 2 C_m <= 2) is ~3e-5 abs, exp(-phase^2 var) (argument up to 95, 3 + 2|x| ulp) is
# ~2e-5 rel of a term < 1; the trigonometric functions' ~1e-6 abs -> 1e-4 abs over the two m
PARITY_CASES = [
    ParityCase("ior_to_fresnel0", (Arg(lo=1.0, hi=3.0, components=3, adversarial=((1, 1, 1),)),
                                   _IOR),
               atol=1e-7, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="a difference, a sum, a division (2.5 ulp) and a square: ~6 roundings "
                        "of a value < 1 -> 4e-7 rel"),
    ParityCase("fresnel0_to_ior", (_F0,), atol=1e-6, rtol=2e-6,
               measured="max rel 2.4e-5 on llvmpipe and 2.7e-4 on the H200 as (1 + s) / (1 - s) "
                        "(1 - s cancels at the clamp: one ulp of s is 1.2e-3 there)",
               envelope="(1 + s)^2 / (1 - f0): sqrt (as 1 / inversesqrt: 3 ulp) halved by "
                        "1 + s, a square (2 x that + 1), 1 - f0 exact (Sterbenz, f0 >= 0.5) or "
                        "1 ulp, a 2.5 ulp division: ~8 ulp a side, 16 x 2^-24 = 1e-6 rel"),
    ParityCase("iridescence_film_ior", (_IOR, _IOR, _NM), atol=1e-6, rtol=1e-6,
               measured="max abs 2.4e-7 (seeds 0-7)",
               envelope="smoothstep (a division, 3 products) and a mix of values <= 2.5: "
                        "~6 roundings -> 4e-7 abs"),
    ParityCase("iridescence_sensitivity",
               (Arg(lo=0.0, hi=4800.0, adversarial=(0.0, 1.0, 400.0, 4800.0)),
                Arg(lo=0.0, hi=6.3, components=3, adversarial=((0, 0, 0), (3.14159, 0, 3.14159)))),
               atol=1e-4, rtol=1e-4, measured="max abs 9.2e-6 (seeds 0-7)",
               envelope="cos(pos phase + shift) at arguments up to 67 rad: 1 ulp there (7.6e-6) "
                        "times the amplitude (<= 1.4 after the 3 x 3 matrix) and the "
                        "trigonometric functions' 1e-6 -> 3e-5 abs; exp's 3 + 2|x| ulp at "
                        "|x| <= 95 -> 2e-5 rel"),
    ParityCase("iridescence_fresnel", (Arg(lo=1.0, hi=1.6, adversarial=(1.0, 1.5)), _IOR, _COS,
                                       _NM, _F0),
               atol=3e-4, rtol=1e-4, measured="max abs 1.5e-6 (seeds 0-7)",
               envelope="two interference terms 2 C_m S_m (|C_m| <= 1) at the sensitivity's "
                        "3e-5 abs each, their OPD = 2 eta d cos theta2 (5 roundings, times "
                        "the phase's 67 rad: 4e-5 rad), sqrt and divisions of R123 near its "
                        "0.9999 clamp (1 / (1 - R123) amplifies 1 ulp 1e4 x: 1e-3 rel of Rs "
                        "there) -> 3e-4 abs"),
    ParityCase("schlick_to_f0", (Arg(lo=0.0, hi=1.0, components=3), _COS, _COS),
               atol=2e-5, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7)",
               envelope="x^5 (5 roundings), a multiply-add and a division by 1 - x^5 floored at "
                        "1e-4: 1 ulp of x^5 near 1 is amplified 1e4 x at the floor -> 1.2e-5 "
                        "abs, before the clamp to [0, 1]"),
    ParityCase("iridescence_outside_ior", (Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, -0.5, 2.0)),),
               atol=1e-7, rtol=1e-7, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="a mix of 1 and 1.5 by a clamped factor: 2 roundings of a value <= 1.5 "
                        "-> 2.4e-7 abs"),
    ParityCase("iridescence_fresnel_mix", (_F0, _COS, _COS, _FILM, _OUTSIDE), atol=3e-4, rtol=1e-4,
               measured="max abs 1.1e-5 (seeds 0-7)", prepare=_film,
               envelope="iridescence_fresnel's 3e-4 abs (a mix with weight <= 1)"),
    ParityCase("iridescence_f0", (_F0, _COS, _COS, _FILM, _OUTSIDE), atol=3e-3, rtol=1e-4,
               measured="max abs 3.6e-5 (seeds 0-7)", prepare=_film,
               envelope="iridescence_fresnel's 3e-4 abs divided by 1 - (1 - n.v)^5, >= 0.41 "
                        "for n.v >= 0.1, floored at 1e-4 at grazing (where the clamp to [0, 1] "
                        "bounds it) -> 3e-3 abs away from the clamp"),
    ParityCase("iridescence_albedo_delta",
               (_F0, _COS, _COS, Arg(lo=0.002, hi=1.0, adversarial=(0.002025, 1.0)), _FILM,
                _OUTSIDE),
               atol=3e-3, rtol=1e-3, measured="max abs 1.8e-6 (seeds 0-7)", prepare=_film,
               envelope="a mean of 32 iridescence_fresnel values (3e-4 abs each) times "
                         "f cos / pdf <= 2.5, and the visible normal's float32 rounding moved "
                         "through the film's phase (67 rad: 1e-5 rad per ulp of v.h) -> "
                         "8e-4 abs; 3e-3 bound"),
]

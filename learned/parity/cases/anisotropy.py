"""Parity cases of ``shaders/lib/anisotropy.glsl`` against :mod:`learned.twins.anisotropy`:
input domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_UNIT01 = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))
_ALPHA = Arg(lo=0.002025, hi=1.0, adversarial=(0.002025, 1.0))  # alpha = r^2, r >= 0.045
_COS = Arg(lo=-1.0, hi=1.0, adversarial=(0.0, 1.0))
_DOT = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-6, 1.0))
_UNIT = Arg(kind="unit", components=3, adversarial=((0, 0, 1), (0, 0, -1), (1, 0, 0)))
_U2 = Arg(components=2, adversarial=((0.0, 0.0), (0.5, 0.5)))

PARITY_CASES = [
    ParityCase("anisotropy_alphas", (_ALPHA, Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 2.0))),
               atol=1e-7, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="mix(a, 1, s^2): a product and a multiply-add of values <= 1, 3 "
                        "roundings -> 1.8e-7 abs (FMA contraction may differ)"),
    ParityCase("d_ggx_anisotropic", (_DOT, _COS, _COS, _ALPHA, _ALPHA),
               atol=1e-6, rtol=2e-5, measured="max rel 5.4e-7 (seeds 0-7; values to 1e21 where h.t = h.b = h.n = 0)",
               envelope="a dot of three squares (no cancellation: 4 roundings), a division "
                        "(2.5 ulp), w2^2 a2 / pi (4 roundings): ~12 ulp -> 7e-7 rel; values "
                        "to 1e11 at alpha 0.002"),
    ParityCase("v_smith_ggx_correlated_anisotropic",
               (_DOT, _DOT, _COS, _COS, _COS, _COS, _ALPHA, _ALPHA),
               atol=1e-6, rtol=2e-5, measured="max rel 2.5e-7 (seeds 0-7)",
               envelope="two lengths (dot + sqrt: 6.5 ulp), two products and a sum of terms "
                        ">= 0, a division (2.5 ulp): ~14 ulp -> 8e-7 rel"),
    ParityCase("sample_ggx_vndf_anisotropic",
               (_U2, Arg(kind="hemisphere", components=3,
                         adversarial=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))), _ALPHA, _ALPHA),
               atol=8e-4, rtol=1e-5, measured="max abs 3.3e-5 (seeds 0-7), near the cap's rim",
               envelope="as sample_ggx_vndf (lib/mc.glsl): z = (1 - u.y)(1 + vh.z) - vh.z "
                        "cancels at the cap's rim and the unstretch divides the error by "
                        "alpha sin_theta: first-order 7.9e-4 abs at the worst draws"),
    ParityCase("pdf_ggx_vndf_anisotropic",
               (Arg(kind="hemisphere", components=3, adversarial=((0.0, 0.0, 1.0),)),
                Arg(kind="hemisphere", components=3, adversarial=((0.0, 0.0, 1.0),)),
                _ALPHA, _ALPHA),
               atol=1e-6, rtol=2e-5, measured="max rel 5.5e-7 (seeds 0-7)",
               envelope="d_ggx_anisotropic (7e-7 rel) / (2 (NoV + length)) (no cancellation, "
                        "~9 ulp) -> 1.3e-6 rel"),
    ParityCase("anisotropy_bent_normal", (_UNIT, _UNIT, _UNIT, _UNIT01, _UNIT01),
               atol=2e-5, rtol=1e-5, measured="max abs 8.8e-7 (seeds 0-7)",
               envelope="two cross products (cancelling differences: ~1 ulp of the inputs' "
                        "products each), a normalisation amplifying them by 1/|bent| (up to "
                        "~1e2 for b nearly parallel to v in 4096 draws), a mix and a second "
                        "normalisation -> 1e-5 abs"),
    ParityCase("anisotropy_encode", (_UNIT, _UNIT, _UNIT01),
               atol=2e-5, rtol=1e-5, measured="max abs 7.7e-7 (seeds 0-7)",
               envelope="tangent_to_world's frame (1 / (1 + |n.z|) amplifies near n.z = -1), two dots and a normalisation amplifying by 1/|d| "
                        "(t nearly along n) -> 1e-5 abs"),
    ParityCase("anisotropy_map_direction",
               (Arg(kind="unit", components=2, adversarial=((1.0, 0.0), (0.0, 1.0))),
                Arg(lo=0.0, hi=1.0, components=3,
                    adversarial=((0.5, 0.5, 1.0), (1.0, 0.5, 0.0), (0.0, 0.0, 0.5)))),
               atol=2e-6, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7)",
               envelope="x 2 - 1 (exact), a normalisation (~3 ulp; the zero vector takes +x "
                        "on both sides) and a 2 x 2 rotation (2 roundings a component): "
                        "~6 ulp of values <= 1 -> 1e-6 abs"),
    ParityCase("anisotropy_decode", (Arg(lo=-1.0, hi=1.0, components=2,
                                         adversarial=((0.0, 0.0), (1.0, 0.0), (0.3, -0.4))),
                                     _UNIT),
               atol=2e-5, rtol=1e-5, measured="max abs 2.4e-7 (seeds 0-7)",
               envelope="a length and a division (~5 ulp), tangent_to_world (its 1 / (1 + "
                        "|n.z|) near n.z = -1 amplifies a few ulp) -> 1e-5 abs"),
    ParityCase("anisotropy_specular_delta",
               (Arg(components=3, adversarial=((0.04, 0.04, 0.04), (1.0, 1.0, 1.0))),
                Arg(adversarial=(1.0,)), _UNIT, _UNIT, _UNIT, _UNIT,
                Arg(lo=0.002025, hi=1.0, components=2, adversarial=((0.5, 0.002025),))),
               atol=1e-5, rtol=3.5e-3,
               measured="max rel 1.9e-3 (abs 1.8 on values to 1e4; seeds 0-7): d_ggx at small alpha",
               envelope="as clearcoat_light (lib/layers.glsl): D_GGX's sensitivity to 1-ulp "
                        "differences in n.h at small alpha, first-order 3.5e-3 rel of each "
                        "term; the difference of the two terms cancels where the lobes agree "
                        "(atol)"),
    ParityCase("anisotropy_albedo_ratio",
               (Arg(kind="hemisphere", components=3, adversarial=((0.0, 0.0, 1.0),
                                                                (0.99, 0.0, 0.141))),
                Arg(lo=0.002025, hi=1.0, components=2, adversarial=((0.67, 0.09),))),
               atol=1e-4, rtol=1e-4, measured="max abs 1.1e-6 (seeds 0-7)", n=1024,
               envelope="32 visible-normal draws (sample_ggx_vndf_anisotropic: up to 8e-4 abs "
                         "at a cap's rim, usually 1e-7) and their G2 / G1 terms summed: a draw "
                         "whose l crosses the horizon between the two sides flips a term"),
]

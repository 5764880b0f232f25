"""Parity cases of ``shaders/lib/brdf.glsl`` against :mod:`learned.twins.brdf`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_DOT = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0, 1e-7, 0.9999999, -0.5, 1.5))


_ALPHA = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-6, 0.002025, 1.0))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("clamp_perceptual_roughness", (Arg(lo=-1, hi=2, adversarial=(0.0, 0.045, 1.0)),),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: clamp returns the input or a float32 literal (0.045, 1) rounded "
                        "alike on both sides"),
    ParityCase("compute_f0", (Arg(components=3), Arg(lo=-0.5, hi=1.5, adversarial=(0.0, 1.0)),
                              Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.5, 1.0))),
               atol=1e-7, rtol=1e-6,
               measured="exact on llvmpipe (seeds 0-7); x87 (nosse) path: max rel 2.3e-7",
               envelope="0.16 s s (2 products), mix as x(1-a)+ya or x+a(y-x) (drivers differ), "
                        "all terms >= 0: ~5 roundings per side -> 6e-7 rel; the y-x form adds "
                        "2u x a <= 2e-8 abs (u = 2^-24, x = 0.16 s^2 <= 0.16)"),
    ParityCase("f90_from_f0", (Arg(components=3, adversarial=((0, 0, 0), (0.02, 0.02, 0.02),
                                                           (1, 1, 1), (0.001, 0, 0))),),
               atol=1e-7, rtol=1e-6, measured="max abs 6e-8 (seeds 0-7)",
               envelope="dot with 16.5 (50 * 0.33 folds to 16.5 exactly): 3 products + 2 adds "
                        "of terms >= 0 in any order, 5 roundings per side -> 3.6e-7 rel; clamp "
                        "is 1-Lipschitz; f0 = 0 exact"),
    # KHR_materials_ior / _specular: ior 0 (infinite), 1 (F0 = 0), glass, diamond, a huge one;
    # colour factors above 1 (the spec allows them; the min clamps F0 at 1)
    ParityCase("dielectric_f0_ior",
               (Arg(lo=1.0, hi=3.0, adversarial=(0.0, 1.0, 1.5, 2.42, 1e6)),
                Arg(lo=0.0, hi=4.0, components=3, adversarial=((1, 1, 1), (0, 0, 0),
                                                                (100, 1, 0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))),
               atol=1e-7, rtol=1e-6, measured="exact on llvmpipe (seeds 0-7)",
               envelope="((ior - 1) / (ior + 1))^2: 2 adds, a division (2.5 ulp), a square, then "
                        "2 products: ~7 roundings per side -> 8e-7 rel; min is exact"),
    ParityCase("surface_f0_f90",
               (Arg(components=3), Arg(lo=-0.5, hi=1.5, adversarial=(0.0, 1.0)),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 0.5, 1.0)),
                Arg(lo=-1.0, hi=1.0, components=4,
                    adversarial=((0, 0, 0, -1), (0.04, 0.04, 0.04, 1), (0, 0, 0, 0), (1, 1, 1, 1)))),
               atol=1e-7, rtol=1e-6, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="either compute_f0 and f90_from_f0 (their envelopes: 6e-7 rel, 3.6e-7 "
                        "rel) or two mixes of terms >= 0 (x(1-a)+ya or x+a(y-x): 5 roundings "
                        "-> 6e-7 rel, the y-x form 2u abs); the branch on a < 0 is exact"),
    ParityCase("d_ggx", (_DOT, _ALPHA), atol=0.0, rtol=1e-5,
               measured="exact on llvmpipe (seeds 0-7); x87 path: max rel 3.7e-7",
               envelope="f = NoH^2 a2 + (1 - NoH)(1 + NoH), sums of terms >= 0 (~4 x 2^-24), f^2, "
                        "pi f^2, a2 / (2.5 ulp): ~14 ulp both sides -> 1.7e-6 rel (inputs exact, "
                        "so no n.h conditioning here)"),
    ParityCase("v_smith_ggx_correlated", (_DOT, _DOT, _ALPHA), atol=0.0, rtol=1e-5,
               measured="max rel 2.2e-7 (seeds 0-7; sqrt/division rounding)",
               envelope="two sqrt (1/inversesqrt: 4.5 ulp) of sums of terms >= 0, products, "
                        "0.5 / x (2.5 ulp): ~12 ulp both sides -> 1.4e-6 rel"),
    ParityCase("f_schlick", (Arg(components=3, adversarial=((0.04, 0.04, 0.04), (1.0, 1.0, 1.0))),
                             Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0)), _DOT),
               atol=1.3e-6, rtol=1e-6,
               measured="max abs 1.2e-7 on llvmpipe (seeds 0-2) as f0 (1 - x^5) + f90 x^5",
               envelope="f0 (1 - x^5) + f90 x^5, 1 - x^5 = c (1 + x (1 + x (1 + x (1 + x)))): "
                        "two terms >= 0, nothing cancels (the form f0 + (f90 - f0) x^5 did, for "
                        "f90 < f0 and c -> 0); x = 1 - c rounds by 2^-25 abs, x^5 carries 5 x that "
                        "+ 3 products: ~9u (u = 2^-24) of terms <= 1, + 4u Horner, + 2u the "
                        "blend, per side -> 1.3e-6 abs bounds it with room"),
    ParityCase("fd_lambert", (), atol=0.0, rtol=1e-7, measured="exact",
               envelope="exact: one float32 literal (1/pi) on both sides"),
    ParityCase("d_blinn_phong",
               (_DOT, Arg(lo=0.0, hi=2000.0, adversarial=(0.0, 1.0, 16384.0, 1e6))),
               atol=1e-6, rtol=5.5e-3,
               measured="max rel 2.6e-4 at NoH = 0.9999999, s = 16384 (seeds 0-7)",
               envelope="pow = exp2(s log2 x): log2 abs error 2^-21 in [0.5, 2] times s ln 2 -> "
                        "16384 x 0.69 x 4.8e-7 = 5.4e-3 rel at s = 16384 (rtol widened from "
                        "5e-4); exp2 (3 + 2|y|) ulp <= 3e-5 before underflow; 3 more roundings"),
    ParityCase("blinn_phong_shininess", (_ALPHA,), atol=1e-6, rtol=1e-6,
               measured="exact on llvmpipe (seeds 0-7); x87 path: 6e-8 abs at a -> 1",
               envelope="2/a2 - 2: division 2.5 ulp (+0.5 torch) + a*a rounding (2 x 0.5 ulp) of "
                        "2/a2 in [2, 4) -> 4 ulp x 2.4e-7 = 9.5e-7 abs where it cancels (a -> 1; "
                        "atol widened from 0); elsewhere 4 ulp = 4.8e-7 rel"),
]

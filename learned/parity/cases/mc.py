"""Parity cases of ``shaders/lib/mc.glsl`` against :mod:`learned.twins.mc`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

_UINT24 = Arg(kind="int", lo=0, hi=(1 << 24) - 1, adversarial=(0.0, 1.0, 16777215.0))


_SMALL = Arg(kind="int", lo=0, hi=4095, adversarial=(0.0, 4095.0))


_U2 = Arg(components=2, adversarial=((0.0, 0.0), (0.9999999, 0.9999999), (0.5, 0.0)))


_ALPHA = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 1.0))


_DOT = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-6, 1.0))


_NOH = Arg(lo=-0.2, hi=1.0, adversarial=(-1.0, 0.0, 1e-6, 1.0))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("hash_u32", (_UINT24,), atol=0.0, rtol=0.0,
               measured="bit-exact (the float conversion of the uint result rounds alike)",
               envelope="exact: integer ops mod 2^32; uint -> float32 conversion correctly "
                        "rounded on both sides"),
    ParityCase("mc_scramble", (_SMALL, _SMALL, _SMALL, Arg(kind="int", lo=0, hi=16)),
               atol=0.0, rtol=0.0, measured="bit-exact", n=1024,
               envelope="exact: integer ops mod 2^32; uint -> float32 conversion correctly "
                        "rounded on both sides"),
    ParityCase("sobol2_bits", (_UINT24,), atol=0.0, rtol=0.0, measured="bit-exact",
               envelope="exact: integer ops; uint -> float32 conversion correctly rounded"),
    ParityCase("sobol_2d", (_UINT24, _UINT24, _UINT24), atol=0.0, rtol=0.0, measured="bit-exact",
               n=1024,
               envelope="exact: integer ops, 24-bit values convert exactly, x 2^-24 is exact"),
    ParityCase("mc_sample_2d", (_SMALL, _SMALL, _SMALL, _SMALL, Arg(kind="int", lo=0, hi=3)),
               atol=0.0, rtol=0.0, measured="bit-exact", n=1024,
               envelope="exact: integer ops, 24-bit values convert exactly, x 2^-24 is exact"),
    ParityCase("sample_uniform_hemisphere", (_U2,), atol=2e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7); nosse (x87): 6.8e-7",
               envelope="r (cos, sin) phi: trig ~1e-6 abs (assumed) + 2 pi u.y rounding 2.4e-7 "
                        "+ sqrt 5 ulp + product -> 2e-6 r; 1 - z z with FMA: z z's rounding is "
                        "<= min(2^-25, (1 - z)^2) -> <= 8e-7 in r (at 1 - z = 1.7e-4) -> 2e-6 "
                        "abs (atol widened from 1e-6); z exact"),
    ParityCase("sample_cosine_hemisphere", (_U2,), atol=2e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7); nosse (x87): 2.4e-7",
               envelope="r (cos, sin) phi, r = sqrt(u.x): trig ~1e-6 abs (assumed) + 2 pi u.y "
                        "rounding 2.4e-7 + sqrt 5 ulp + product -> 2e-6 abs (first-order on the "
                        "draws 1.75e-6; atol widened from 1e-6); z = sqrt(1 - u.x): 5 ulp rel"),
    ParityCase("pdf_cosine_hemisphere", (Arg(lo=-1.0, hi=1.0, adversarial=(0.0, 1.0)),),
               atol=0.0, rtol=1e-7, measured="exact",
               envelope="exact: one correctly rounded product with the same 1/pi literal"),
    ParityCase("g1_smith_ggx", (_DOT, _ALPHA), atol=1e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="sqrt (4.5 ulp) of a sum of terms >= 0, NoV + sqrt (no cancellation), "
                        "2 NoV / x (2.5 ulp): ~10 ulp both sides -> 1.2e-6 rel"),
    ParityCase("sample_ggx_vndf",
               (_U2, Arg(kind="hemisphere", components=3,
                         adversarial=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.6, 0.8, 0.0))),
                _ALPHA),
               atol=8e-4, rtol=1e-5,
               measured="max abs 1.3e-6 on llvmpipe (seeds 0-2) with the cap's z as e = 1 + z "
                        "and hh.z = e - d; 2.8e-5 before, and 0.03 on the H200 at u.y = "
                        "0.9999999, v = +Z, where z + vh.z cancelled vh.z's last ulps",
               envelope="h = normalize(a hh.xy, hh.z), hh -> 0 at the cap's rim (u.y -> 1): "
                        "hh.z = e - d with e = (1 - u.y)(1 + vh.z) + d, d = |vh.xy|^2 / "
                        "(1 + vh.z), so normalize's ulps no longer cancel; what is left moves h "
                        "by ~ulp / (a sin_theta) near the horizon (e ~ d). The tolerance is the "
                        "old form's first-order bound (max 7.9e-4 over seeds 0-63), kept, not "
                        "re-derived for the new form"),
    ParityCase("pdf_ggx_vndf", (_DOT, _NOH, _ALPHA), atol=1e-6, rtol=2e-5,
               measured="max rel 2.1e-7 (seeds 0-7; values to 1e7 at alpha 1e-4)",
               envelope="d_ggx (14 ulp) / (2 (NoV + sqrt(...))) (sqrt 4.5 ulp, / 2.5 ulp, no "
                        "cancellation): first-order 3e-6 rel; NoH > 0 compares the input"),
    ParityCase("ggx_specular_brdf",
               (Arg(components=3, adversarial=((0.04, 0.04, 0.04), (1.0, 1.0, 1.0))),
                Arg(adversarial=(0.0, 1.0)), _DOT, _DOT, _DOT, _DOT, _ALPHA),
               atol=1e-6, rtol=2e-5, measured="max rel 2.4e-7 (seeds 0-7)", n=1024,
               envelope="D (14 ulp) V (12 ulp) F (f_schlick, ~15 ulp rel: its two terms never "
                        "cancel): first-order on the random draws <= 73% of the tolerance, also "
                        "at the grid's f0 = 1, f90 = 0, VoH = 1e-6 (F = 5e-6, D V ~1e11), where "
                        "the old f0 + (f90 - f0) x^5 cancelled: 0.74 % apart on an H200"),
    ParityCase("specular_lobe_probability",
               (Arg(components=3, adversarial=((0.0, 0.0, 0.0),)),
                Arg(components=3, adversarial=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))),
                Arg(adversarial=(0.0, 1.0)), _DOT),
               atol=4e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7); nosse: 3e-7",
               envelope="s / (s + d): s = Y.F carries f_schlick's 1.3e-6 abs where f90 < f0 "
                        "cancels, so dp <= 1.3e-6 / (s + d) + 3 ulp; first-order on the draws "
                        "(seeds 0-63) 3.7e-6 abs (atol widened from 1e-6)"),
    ParityCase("mis_weight",
               (Arg(lo=0.0, hi=100.0, adversarial=(0.0, 1e-18, 1e8)),
                Arg(lo=0.0, hi=100.0, adversarial=(0.0, 1e8)),
                Arg(kind="int", lo=1, hi=2, adversarial=(1.0, 2.0))),
               atol=1e-7, rtol=1e-6, measured="exact (seeds 0-7)",
               envelope="a^2 / (a^2 + b^2) or a / (a + b), terms >= 0: 3 roundings + / 2.5 ulp "
                        "-> 7e-7 rel; tiny pdf 1e-18, not 1e-30, whose square underflows float32 "
                        "(weight 0) but not wider arithmetic (x87 nosse: 1)"),
]

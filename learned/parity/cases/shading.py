"""Parity cases of ``shaders/lib/shading.glsl`` against :mod:`learned.twins.shading`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase


def _nonneg3(hi=1.0, adv=()):
    return Arg(lo=0.0, hi=hi, components=3, adversarial=adv)


def _fix_dfg_at(index):
    """Keep argument ``index`` (dfg) in the LUT's range: it never holds dfg.y = 0 or
    dfg.x > dfg.y."""

    def fix(args):
        dfg = args[index]
        dfg[:, 1] = dfg[:, 1].clip(1e-3, 1.0)
        dfg[:, 0] = dfg[:, 0].clip(0.0, None) * dfg[:, 1]
        return args
    return fix


_UNIT = Arg(kind="unit", components=3, adversarial=((0, 0, 1),))


def _near_horizon(args):
    """Put l (argument 1) within +-radius of n's horizon for three rows in four: the disc light's
    clipped branch."""
    import numpy as np

    n, l, radius = args
    rng = np.random.default_rng(5)
    t = l - (l * n).sum(-1, keepdims=True) * n
    norm = np.linalg.norm(t, axis=-1, keepdims=True)
    t /= np.maximum(norm, 1e-6)
    nol = rng.uniform(-1.0, 1.0, len(n)) * np.sin(radius)
    moved = t * np.sqrt(1.0 - nol ** 2)[:, None] + nol[:, None] * n
    pick = (rng.random(len(n)) < 0.75) & (norm[:, 0] > 1e-3)
    length = np.maximum(np.linalg.norm(moved, axis=-1, keepdims=True), 1e-12)  # 0: not picked
    l[pick] = (moved / length)[pick].astype(l.dtype)
    return args


_UP = Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1), (1, 0, 0)))


_ALPHA_L = Arg(lo=0.0, hi=1.0, adversarial=(0.002025, 1.0))
_UNIT_RANGE = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))  # n.v, ao
# f90: surface_f0_f90's (Filament's f90_from_f0, or KHR_materials_specular's factor), in [0, 1]
_F90 = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("diffuse_color", (_nonneg3(), Arg(lo=-0.5, hi=1.5, adversarial=(0.0, 1.0))),
               atol=0.0, rtol=2.4e-7, measured="exact on llvmpipe (seeds 0-7); nosse: 1.2e-7 rel",
               envelope="albedo (1 - m): 2 roundings per side (1 - m may stay unrounded, x87) "
                        "-> 4 x 2^-24 = 2.4e-7 rel (rtol widened from 1e-7)"),
    ParityCase("shading_normal",
               (Arg(kind="unit", components=3, adversarial=((0, 0, 0), (0, 0, -1), (0, 0, 1e-7),
                                                            (1, 0, 0), (0, 0, 5))),
                Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1),))),
               atol=1.25e-4, rtol=1e-5,
               measured="max abs 2.4e-6 (seeds 0-7); nosse: 4.3e-6 (seeds 1, 7)",
               envelope="bent = n + (1e-4 - n.v) v for back-facing n: its ~4 x 2^-24 abs per "
                        "component per side (dot, product, add) divide by |bent| >= |n_perp| "
                        "(>= 1e-4): first-order on the draws (seeds 0-63) median 1.6e-5, max "
                        "1.22e-4 abs (atol widened from 2e-6; heavy tail as n -> -v); "
                        "front-facing n inversesqrt(len2): ~10 x 2^-24"),
    ParityCase("ggx_split_sum",
               (_nonneg3(), _nonneg3(), _F90, Arg(), _nonneg3(10.0),
                _nonneg3(100.0, ((1e5, 0, 65504),)),
                Arg(lo=0.0, hi=1.0, components=2), Arg(kind="int", lo=0, hi=1)),
               atol=4e-6, rtol=2e-6, measured="max rel 4.2e-7 (seeds 0-7)",
               prepare=_fix_dfg_at(6),
               envelope="1 - e_spec cancels as e_spec -> 1: e_spec (~8 roundings + 1/dfg.y at "
                        "2.5 ulp) ~20 x 2^-24 = 1.2e-6 of <= ~1, times diffuse E ao / pi <= "
                        "10/pi -> 3.8e-6 abs (atol widened from 1e-6; first-order on the draws "
                        "2.1e-6); otherwise ~6 roundings of terms >= 0 -> 7e-7 rel"),
    # n.v and ao over [0, 1] with their ends, alpha from the clamp's floor to 1
    ParityCase("specular_occlusion",
               (_UNIT_RANGE, _UNIT_RANGE, _ALPHA_L),
               atol=2e-6, rtol=0.0, measured="max abs 2.4e-7 on llvmpipe",
               envelope="pow(x, p) = exp2(p log2 x) with x = n.v + ao <= 2, p <= 0.5: a result "
                        "<= sqrt 2 within ~3 ulp (2.5e-7) per side, then - 1 + ao: 2 roundings "
                        "of values <= 2 (2.4e-7); ~1e-6 abs between the sides at worst, atol "
                        "2e-6 (the result's cancellation makes rel meaningless near 0)"),
    ParityCase("blinn_phong",
               (_nonneg3(), _nonneg3(), Arg(), _nonneg3(10.0), _nonneg3(100.0, ((1e5, 0, 65504),))),
               atol=1e-6, rtol=2e-6, measured="max rel 1.9e-7 (seeds 0-7)",
               envelope="diffuse E / pi ao (1 - f0) + f0 P: 1 - f0 cancels only where its term "
                        "vanishes; ~6 roundings per side of terms >= 0 -> 7e-7 rel"),
    # n anywhere, v and l anywhere on the sphere (n.l <= 0 gives 0); E up to the fp16 maximum
    ParityCase("ggx_directional_light",
               (_nonneg3(), _nonneg3(), _F90, _ALPHA_L, Arg(lo=0.0, hi=1.0, components=2),
                Arg(kind="int", lo=0, hi=1), _UNIT, _UP, _UNIT, _nonneg3(10.0, ((1e5, 0, 65504),))),
               atol=1e-6, rtol=3.5e-3, prepare=_fix_dfg_at(4),
               measured="max rel 7.0e-5 (seeds 0-7): at alpha 0.002 D_GGX turns 1-ulp differences "
                        "in n.h (inversesqrt, dot order) into ~1e-5 relative",
               envelope="dD/D = 4 dNoH / (a^2 + 2 (1 - NoH)); NoH = dot(n, normalize(v + l)) "
                        "carries ~18 x 2^-24 both sides (inversesqrt 2 ulp, dots in any order): "
                        "first-order on the random draws (seeds 0-63) median 4e-4, max 3.5e-3 "
                        "rel (rtol widened from 2e-4; heavy tail); NOT covered: grid n = v = l "
                        "= +Z, a = 0.002025: NoH = 1 needs inversesqrt(4) = 0.5 exactly (D -35% "
                        "if 2 ulp off)"),
    # alpha over the whole range, the sun's radius from a point (floored) to 0.2 rad
    ParityCase("sun_specular_weight", (Arg(lo=0.0, hi=1.0), Arg(lo=0.0, hi=0.2)),
               atol=1e-6, rtol=1e-6, measured="exact (seeds 0-3)",
               envelope="one division and one fma before the clamp: 2 ulp of values <= 1"),
    # the same with the specular weight w in [0, 1] (the environment's sun, viewer/environment/sun.py)
    ParityCase("ggx_environment_sun",
               (_nonneg3(), _nonneg3(), _F90, _ALPHA_L, Arg(lo=0.0, hi=1.0, components=2),
                Arg(kind="int", lo=0, hi=1), _UNIT, _UP, _UNIT, _nonneg3(10.0, ((1e5, 0, 65504),)),
                Arg(lo=0.0, hi=1.0)),
               atol=1e-6, rtol=3.5e-3, prepare=_fix_dfg_at(4),
               measured="max rel 7.0e-5 (seeds 0-3), as ggx_directional_light (the same body)",
               envelope="as ggx_directional_light: D_GGX's sensitivity to n.h at small alpha; "
                        "w adds one rounding"),
    ParityCase("atan_minus_z", (Arg(lo=0.0, hi=0.5, adversarial=(0.0, 0.3499, 0.35, 1e-4, 5.0)),),
               atol=2e-6, rtol=1e-5, measured="max abs 1.5e-6 (above 0.1: atan's own error)",
               envelope="series below 0.35: 16 roundings in Horner form with terms "
                        "alternating at ratio z^2 < 0.13 -> 20 ulp rel; above, atan's assumed "
                        "1e-6 abs per side: 2e-6 abs"),
    # the light near the normal's horizon for most draws (prepare), the radius up to 0.1 rad
    # (extracted lights are below 0.08: SUN_MAX_SOLID_ANGLE)
    ParityCase("disc_light", (_UNIT, _UNIT, Arg(lo=0.0, hi=0.1, adversarial=(0.0, 0.005, 0.08))),
               atol=3e-3, rtol=5e-4, prepare=_near_horizon,
               measured="max abs 2.1e-3 (seeds 0-3) where the disc is nearly set and s = c / "
                        "1e-3; max rel 2.9e-4 elsewhere",
               envelope="c: NoL acos(y) + z + .. cancel as the disc sets (terms ~100x the "
                        "result): acos's and atan's assumed 1e-6 abs and the terms' roundings "
                        "-> 3e-6 abs on c, over n.l_b = 1e-3 where lifted -> 3e-3 abs on s "
                        "(3e-6 E on the irradiance); n.l_b = 1e-3 carries ~3 ulp of 1 (the "
                        "normalize): 2e-4 rel on s; l_b: normalize, 4 ulp"),
    ParityCase("blinn_phong_directional_light",
               (_nonneg3(), _nonneg3(), _ALPHA_L, _UNIT, _UP, _UNIT,
                _nonneg3(10.0, ((1e5, 0, 65504),))),
               atol=1e-6, rtol=2.3e-2,
               measured="max rel 4.1e-4 (seeds 0-7): (n.h)^s with s up to 16384 (GLSL pow = "
                        "exp2(s log2 x)) on 1-ulp differences in n.h",
               envelope="(n.h)^s, s = 2/a^2 - 2 <= 16384: s dNoH / NoH with dNoH ~18 x 2^-24 -> "
                        "1.8e-2, + pow's log2 (2^-21 abs) x s ln 2 -> 5.4e-3: 2.3e-2 rel (rtol "
                        "widened from 1e-3; first-order on the draws 2.2e-2, median 6.5e-4)"),
]

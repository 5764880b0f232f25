"""Parity cases of ``shaders/lib/ibl.glsl`` against :mod:`learned.twins.ibl`: input
domains, adversarial values and tolerances with the envelope each guards."""
from __future__ import annotations

from .base import Arg, ParityCase

# Functions taking samplers (or arrays) covered by the pass checks registered below.
PASS_LEVEL = ("ibl_specular_radiance", "ibl_dfg", "ibl_dominant_factor",
              "ibl_specular_radiance_sun", "irradiance_lookup")


_DFG = Arg(lo=0.0, hi=1.0, components=2, adversarial=((0.0, 1.0), (1.0, 1.0), (0.5, 1e-6)))


_F0 = Arg(components=3, adversarial=((0.04, 0.04, 0.04), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)))


PARITY_CASES = [
    ParityCase("prefilter_lod", (Arg(lo=0.0, hi=1.0,
                                     adversarial=(0.0, 0.045, 0.125, 0.25, 0.5, 1.0, -1.0, 2.0)),
                                 Arg(kind="int", lo=1, hi=8, adversarial=(1.0, 2.0, 6.0))),
               atol=5e-6, rtol=1e-6, measured="max abs 4.8e-7",
               envelope="log2(alpha) for alpha down to 2^-6 (|log2| <= 6): 3 ulp = 2.1e-6 abs, "
                        "alpha = r^2 1 ulp (1.7e-7 in log2), exp2 of an integer exact, the add "
                        "to levels - 1 <= 7 half an ulp (2.4e-7); below level 1 a / a1 2.5 ulp "
                        "of values <= 1 -> atol 5e-6"),
    ParityCase("specular_dominant_direction",
               (Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1),)),
                Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1), (1, 0, 0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1.0))),
               atol=2e-6, rtol=0.0, measured="max abs 1.2e-7",
               envelope="mix (2 ops, or 1 fma) and normalize (dot, inversesqrt 2 ulp, multiply): "
                        "~5 ulp of |n| + |r| over |mix(n, r, t)| (>= 0.02 for these inputs: "
                        "hemisphere vectors drawn at random, t in [0, 1]) -> 6e-7 / |mix|"),
    ParityCase("ibl_specular_dfg", (_DFG, _F0, Arg(adversarial=(0.0, 1.0))), atol=3e-7, rtol=1e-6,
               measured="max abs 1.2e-7 (fma rounding)",
               envelope="f0 (y - x) + f90 x: 4 ops, with or without FMA contraction 2 ulp of "
                        "terms <= 1 -> 2.4e-7 abs"),
    ParityCase("ibl_energy_compensation", (_DFG, _F0), atol=0.0, rtol=1e-6,
               measured="max rel 1.2e-7",
               envelope="1 + f0 (1 / y - 1): reciprocal 2.5 ulp, 3 correctly rounded ops, no "
                        "cancellation (1 / y >= 1): 5.5 ulp = 6.6e-7 rel"),
]

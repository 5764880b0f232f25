"""Parity cases of ``shaders/lib/antialias.glsl`` against :mod:`learned.twins.antialias`: input
domains, adversarial values and tolerances with the envelope each guards. The functions that take
a sampler are compared by the pass check ``antialias`` (:mod:`learned.parity.checks.antialias`)."""
from __future__ import annotations

from .base import Arg, ParityCase

PASS_LEVEL = ("fxaa_fetch", "fxaa_luma_at", "fxaa", "ssaa_resolve")

PARITY_CASES = [
    ParityCase("fxaa_luma", (Arg(lo=0.0, hi=1.0, components=3,
                                 adversarial=((0, 0, 0), (1, 1, 1))),),
               atol=2e-7, rtol=1e-6, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="a 3-term dot product of values in [0, 1] with positive weights summing "
                        "to 1: 3 roundings (any order, FMA or not) -> 1.8e-7 abs"),
    ParityCase("fxaa_texel", (Arg(lo=0.0, hi=1.0, components=4,
                                  adversarial=((0, 0.04045, 1, 0.5),)),),
               atol=2e-6, rtol=1e-5, measured="max abs 3.6e-7 (seeds 0-7)",
               envelope="srgb_to_linear's envelope (6e-6 rel: its case in cases/tonemap.py) on "
                        "rgb and fxaa_luma's (1.8e-7 abs) in alpha"),
]

"""The function parity cases, one module per ``shaders/lib`` file (``cases/brdf.py`` for
``lib/brdf.glsl`` and its twin ``learned/twins/brdf.py``): how to draw random and adversarial inputs
for each GLSL function, its tolerance, the error measured on llvmpipe and the envelope the
tolerance guards. ``PASS_LEVEL`` names the functions that take samplers or structs, which the pass
checks (:mod:`learned.parity.checks`) cover instead."""
from __future__ import annotations

from . import (
    anisotropy,
    antialias,
    brdf,
    bvh,
    common,
    contact,
    denoise,
    env_sampling,
    equirect,
    ground,
    ibl,
    iridescence,
    layers,
    lights,
    mc,
    neural,
    path,
    sampling,
    sh,
    shading,
    shadow,
    shadow_net,
    splat,
    ssao,
    tonemap,
    transmission,
)
from .base import Arg, ParityCase

MODULES = (anisotropy, antialias, brdf, bvh, common, contact, denoise, env_sampling, equirect, ground, ibl,
           iridescence, layers, lights, mc, neural, path, sampling, sh, shading, shadow, shadow_net, splat, ssao, tonemap,
           transmission)

__all__ = ["Arg", "ParityCase", "MODULES", "all_cases", "pass_level"]


def all_cases() -> list[ParityCase]:
    return [case for mod in MODULES for case in getattr(mod, "PARITY_CASES", ())]


def pass_level() -> set[str]:
    return {name for mod in MODULES for name in getattr(mod, "PASS_LEVEL", ())}

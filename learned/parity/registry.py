"""The registry of pass-level parity checks, explicit: every module of :mod:`learned.parity.checks`
is named here, and ``tests/shaders/test_library_parity.py`` runs every entry, so no check can be
registered and forgotten. Nothing registers itself on import."""
from __future__ import annotations

from typing import Callable

from .checks import (
    antialias,
    env_sampling,
    forward,
    ibl,
    models,
    neural,
    raytrace,
    shadow,
    shadow_lights,
    shadow_net,
    splats,
    ssao,
)

CHECK_MODULES = (ibl, models, forward, env_sampling, neural, splats, ssao, shadow, shadow_lights,
                 antialias, raytrace, shadow_net)

_REGISTRY: dict[str, tuple[str | None, Callable]] = {}


def pass_checks() -> dict[str, tuple[str | None, Callable]]:
    """name -> (the model the check belongs to, or None; ``check(programs) -> results``)."""
    if not _REGISTRY:
        for mod in CHECK_MODULES:
            for name, entry in mod.checks().items():
                if name in _REGISTRY:
                    raise ValueError(f"parity check {name!r} registered twice")
                _REGISTRY[name] = entry
    return _REGISTRY


def check_models() -> set[str]:
    """The values ``relight parity --model`` accepts besides shading models (e.g. ``splats``)."""
    return {model for model, _ in pass_checks().values() if model is not None}

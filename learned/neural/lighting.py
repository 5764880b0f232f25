"""Environment lighting for the neural shaders: :func:`lighting_from_gl` reads a renderer's IBL
and sampling tables back into a :class:`Lighting` (the GL side); the torch part (the
:class:`Lighting` resources and the per-pixel lighting features the passes compute from them)
lives in :mod:`learned.neural.torch_lighting`, which the twins import without anything of
``viewer``, and is named here too for the callers that use both.
"""
from __future__ import annotations

import math

import numpy as np
import torch

from learned.neural.torch_lighting import (  # noqa: F401 - names the callers import from here
    STRATEGIES,
    Lighting,
    env_lights_base,
    env_radiance,
    sample_lights,
    student_features,
    surface,
)
from viewer.gl import make_current
from viewer.scene.description import Scene


def lighting_from_gl(renderer, environment, sun: bool = False) -> Lighting:
    """Build (or reuse the renderer's cached) IBL and sampling tables of the
    :class:`~viewer.environment.maps.EnvironmentSpec` ``environment`` on the GPU and read them back.
    ``sun``: the IBL a ``SUN_LIGHT`` pass binds (``GPUResources.ibl(..., sun=True)``: without the
    environment's sun, which ``Lighting.sun`` then holds, with the whole environment's chain in
    ``prefiltered_full``); the plain IBL when the environment has no sun."""
    make_current(renderer.ctx)
    scene = Scene(environment=environment)
    ibl = renderer.resources.ibl(environment, sun=sun)
    full = None
    if ibl.sun is not None:
        plain = renderer.ibl(scene)
        full = [torch.from_numpy(plain.read_level("prefiltered", k)) for k in range(plain.levels)]
    tables = renderer.env_sampling(scene).read()
    t = torch.from_numpy
    return Lighting(
        radiance=t(ibl.read_level("radiance", 0)),
        prefiltered=[t(ibl.read_level("prefiltered", k)) for k in range(ibl.levels)],
        levels=float(ibl.levels), sh=t(np.asarray(ibl.sh, np.float32)),
        irradiance=t(ibl.read_level("irradiance", 0)),
        marginal=t(tables["marginal"]), conditional=t(tables["conditional"]), pdf=t(tables["pdf"]),
        intensity=float(environment.intensity), rotation=math.radians(environment.rotation_deg),
        dfg=t(ibl.read_level("dfg", 0)[..., :2].copy()),
        dominant=t(ibl.read_level("dominant", 0)) if ibl.dominant is not None else None,
        sun=ibl.sun, prefiltered_full=full, lights=tuple(ibl.lights))

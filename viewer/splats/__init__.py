"""3D Gaussian splats: PLY I/O and validation (:mod:`.ply`), the :class:`Splats` arrays
(:mod:`.data`), depth sorting (:mod:`.sort`) and synthetic scenes with known materials and light
(:mod:`.generate`). Rendering: :mod:`viewer.passes.splats` (GLSL) and
:mod:`learned.splats.rasterize` (torch twin)."""
from __future__ import annotations

import dataclasses

import numpy as np

from .data import Splats, concat, make_splats, transform_splats
from .ply import read_ply, write_ply

__all__ = ["Splats", "concat", "load_splats", "make_splats", "read_ply", "transform_splats",
           "write_ply"]


def load_splats(path, transform=None, material=None) -> Splats:
    """A scene's ``type = "splats"`` object: :func:`read_ply`, then the optional row-major 4x4
    ``transform``; a ``material`` (scene ``[objects.material]``) replaces every splat's albedo,
    roughness and metallic."""
    splats = read_ply(path)
    if transform is not None:
        splats = transform_splats(splats, np.asarray(transform, np.float64))
    if material is not None:
        n = len(splats)
        splats = dataclasses.replace(
            splats, albedo=np.tile(np.asarray(material.albedo, np.float32), (n, 1)),
            roughness=np.full(n, material.roughness, np.float32),
            metallic=np.full(n, material.metallic, np.float32), has_materials=True)
    return splats

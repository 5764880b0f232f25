"""3D Gaussian splats: file formats detected by content (:mod:`.formats`: PLY layouts, .splat),
PLY I/O (:mod:`.ply`; SuperSplat's compressed PLY: :mod:`.compressed`), the validation every
reader's fields go through (:mod:`.validate`), the :class:`Splats` arrays (:mod:`.data`), depth
sorting (:mod:`.sort`) and synthetic scenes with known materials and light (:mod:`.generate`).
Rendering: :mod:`viewer.passes.splats` (GLSL) and :mod:`learned.splats.rasterize` (torch twin).

Imports: :mod:`viewer.errors`; no GL.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .data import Splats, concat, make_splats, transform_splats
from .formats import detect_format, read_splat, unsupported
from .ply import read_ply, write_ply
from .validate import fields_to_splats

__all__ = ["Splats", "concat", "load_splats", "make_splats", "read_ply", "read_splats",
           "transform_splats", "write_ply"]


def read_splats(path) -> Splats:
    """Any supported splat file, its format told from the content (:func:`.formats.detect_format`),
    not the extension. Unsupported formats (.spz, .ksplat) are named in a one-line
    :class:`~viewer.errors.InputError`."""
    fmt = detect_format(path)
    if fmt == "ply":
        return read_ply(path)
    if fmt == "splat":
        return fields_to_splats(path, read_splat(path))
    raise unsupported(fmt, path)


def load_splats(path, transform=None, material=None) -> Splats:
    """A scene's ``type = "splats"`` object: :func:`read_splats`, then the optional row-major 4x4
    ``transform``; a ``material`` (scene ``[objects.material]``) replaces every splat's albedo,
    roughness and metallic."""
    splats = read_splats(path)
    if transform is not None:
        splats = transform_splats(splats, np.asarray(transform, np.float64))
    if material is not None:
        n = len(splats)
        splats = dataclasses.replace(
            splats, albedo=np.tile(np.asarray(material.albedo, np.float32), (n, 1)),
            roughness=np.full(n, material.roughness, np.float32),
            metallic=np.full(n, material.metallic, np.float32), has_materials=True)
    return splats

"""Simplified copies of a mesh for its shadow maps: a map whose texels are w wide cannot tell a
caster from one whose surface lies within a fraction of w of it, so the shadow pass draws each
mesh at the coarsest level of detail whose error stays under that fraction
(:mod:`viewer.passes.shadow`, ``[render] shadow_lod_error``). A shadow pass on a software
rasteriser costs per triangle drawn, not per texel, and scanned or finely tessellated meshes carry
far more triangles than a map resolves.

Levels are powers of two of the mesh's size: level k allows an error of size x 2^-k, so the
maps of one scene share a few copies of each mesh however their texels differ. The simplifier is
meshoptimizer's (Garland-Heckbert quadrics with topology kept), run on the welded positions, so
seams split for UVs or normals do not pin it. Its error (world units) measures the kept vertices
against the planes of the faces they replace; the chord sag inside the larger triangles comes on
top: on a sphere the surface strays 1.6-2.1 x the level's bound from the true one
(tests/viewer/test_shadow_casters.py), so half a texel of error moves a silhouette by about one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .solid import solid_orientation, weld

LOD_MIN_TRIANGLES = 512  # smaller meshes are always drawn whole (nothing worth the copy)
LOD_MAX_LEVEL = 24       # finer than size x 2^-24 (float32's resolution): the whole mesh
LOD_MIN_SAVING = 0.75    # a copy keeping more than this share of the triangles is not made


@dataclass(frozen=True)
class SimplifiedMesh:
    """A shadow caster: compact positions ``[N, 3]`` float32, triangles ``[M, 3]`` uint32, the
    simplifier's error (world units, 0 for the whole mesh) and its
    :func:`~viewer.geometry.solid.solid_orientation`."""

    positions: np.ndarray
    indices: np.ndarray
    error: float
    orientation: int

    @property
    def nbytes(self) -> int:
        return int(self.positions.nbytes + self.indices.nbytes)


def lod_level(size: float, tolerance: float) -> int | None:
    """The coarsest level whose error bound ``size`` x 2^-level is at most ``tolerance`` (world
    units), for a mesh ``size`` wide; None (the whole mesh) where no level that fine is kept."""
    if not (tolerance > 0.0 and size > 0.0) or not math.isfinite(size / tolerance):
        return None
    level = max(0, math.ceil(math.log2(size / tolerance)))
    return level if level <= LOD_MAX_LEVEL else None


def mesh_size(positions: np.ndarray) -> float:
    """The largest side of the positions' bounding box."""
    pos = np.asarray(positions, np.float64).reshape(-1, 3)
    return float(np.max(pos.max(axis=0) - pos.min(axis=0))) if len(pos) else 0.0


def whole(positions: np.ndarray, indices: np.ndarray) -> SimplifiedMesh:
    """The mesh itself as a caster (no copy of its arrays)."""
    return SimplifiedMesh(np.asarray(positions), np.asarray(indices).reshape(-1, 3), 0.0,
                          solid_orientation(positions, indices))


def simplify(positions: np.ndarray, indices: np.ndarray, level: int) -> SimplifiedMesh | None:
    """The mesh (``positions`` ``[N, 3]``, ``indices`` ``[M, 3]``) simplified to an error of at
    most its size x 2^-``level`` in world units, compacted to the vertices it uses; None where
    that keeps more than LOD_MIN_SAVING of its triangles, or the mesh has fewer than
    LOD_MIN_TRIANGLES."""
    import meshoptimizer

    tri = np.asarray(indices).reshape(-1, 3)
    if len(tri) < LOD_MIN_TRIANGLES:
        return None
    pos = np.ascontiguousarray(np.asarray(positions, np.float32).reshape(-1, 3))
    size = mesh_size(pos)
    if not (size > 0.0) or not np.isfinite(pos).all():
        return None
    scale = max(size, float(np.abs(pos).max()))
    welded = weld(pos, 1e-6 * scale)[tri].astype(np.uint32).reshape(-1)
    dest = np.zeros_like(welded)
    error = np.zeros(1, np.float32)
    count = meshoptimizer.simplify(dest, welded, pos, target_index_count=0,
                                   target_error=size * 2.0 ** -level,
                                   options=meshoptimizer.SIMPLIFY_ERROR_ABSOLUTE,
                                   result_error=error)
    if count == 0 or count > LOD_MIN_SAVING * len(welded):
        return None
    used, compact = np.unique(dest[:count], return_inverse=True)
    out_pos = np.ascontiguousarray(pos[used])
    out_tri = np.ascontiguousarray(compact.reshape(-1, 3).astype(np.uint32))
    return SimplifiedMesh(out_pos, out_tri, float(error[0]), solid_orientation(out_pos, out_tri))

"""Whether a triangle mesh bounds a solid, and which way its triangles wind: what lets a shadow
pass draw only the faces that turn towards the light.

A ray from a light outside a closed surface enters it before it can leave it, so the nearest
occluder along the ray is always a face that the ray enters. Where a mesh is closed (every edge
shared by exactly two triangles, once in each direction, after welding equal positions) and its
winding is consistent, the entering faces are the ones whose outward normal turns towards the
light, and the shadow pass culls the others: the same map at half the rasterised triangles
(:mod:`viewer.passes.shadow`). An open mesh (a floor, a leaf, a torn scan) is drawn with both
faces, as is any mesh whose edges are not paired.
"""
from __future__ import annotations

import itertools

import numpy as np

OUTWARD, INWARD, OPEN = 1, -1, 0


def solid_orientation(positions: np.ndarray, indices: np.ndarray) -> int:
    """:data:`OUTWARD` where the triangles (``indices``, 3 per triangle, into ``positions``)
    bound a solid and wind counter-clockwise seen from outside (glTF's front faces out),
    :data:`INWARD` where they bound one wound the other way (a room seen from within), :data:`OPEN`
    otherwise (an edge without its reverse, an edge used twice the same way, no volume).
    Positions closer than a millionth of the mesh's size (or of its distance from the origin) are
    one vertex (:func:`weld`: meshes split vertices along UV and normal seams, and a float32
    transform can leave the two sides an ulp apart); triangles with two equal vertices are
    skipped (they bound nothing)."""
    pos = np.asarray(positions, np.float64).reshape(-1, 3)
    tri = np.asarray(indices, np.int64).reshape(-1, 3)
    if len(tri) == 0 or len(pos) == 0:
        return OPEN
    if not np.isfinite(pos).all():
        return OPEN
    scale = max(float(np.max(pos.max(axis=0) - pos.min(axis=0))), float(np.abs(pos).max()))
    labels = weld(pos, 1e-6 * max(scale, 1e-30))
    p = pos[labels]  # each vertex at its group's first one
    t = labels[tri]
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])]
    if len(t) < 4:  # a tetrahedron is the smallest closed surface
        return OPEN
    n = int(t.max()) + 1
    a = t.reshape(-1)
    b = t[:, [1, 2, 0]].reshape(-1)
    edges = np.sort(a * n + b)
    if (np.diff(edges) == 0).any():  # a directed edge twice: non-manifold or inconsistent winding
        return OPEN
    reverse = b * n + a
    found = np.minimum(np.searchsorted(edges, reverse), len(edges) - 1)
    if not np.array_equal(edges[found], reverse):  # an edge without its reverse: a border
        return OPEN
    v0, v1, v2 = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
    volume = float(np.einsum("ij,ij->", v0, np.cross(v1, v2))) / 6.0
    extent = float(np.max(pos.max(axis=0) - pos.min(axis=0)))
    if not np.isfinite(volume) or abs(volume) <= 1e-9 * extent ** 3:
        return OPEN
    return OUTWARD if volume > 0.0 else INWARD


def weld(positions: np.ndarray, tol: float) -> np.ndarray:
    """``[N]`` the index of the first of each group of ``positions`` closer than ``tol / 2`` on
    every axis (and of whatever such pairs chain to): points sharing a cell of any of eight grids
    of cell ``tol``, shifted by half a cell on each combination of axes, are joined. Two points
    nearer than half a cell on an axis straddle a cell edge of at most one of that axis's two
    shifts, so some grid holds both. The points must span fewer than 2^21 cells a side."""
    pos = np.asarray(positions, np.float64).reshape(-1, 3)
    pos = (pos - pos.min(axis=0)) / tol  # cells from 0; under 2^21 a side where tol is at
    n = len(pos)                          # least a millionth of the extent (solid_orientation)
    labels = np.arange(n)
    cells = []
    for shift in itertools.product((0.0, 0.5), repeat=3):
        c = np.floor(pos + np.asarray(shift)).astype(np.int64)
        key = (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]
        cells.append(np.unique(key, return_inverse=True)[1].reshape(-1))
    while True:  # propagate each group's smallest index until no group changes
        before = labels
        for cell in cells:
            least = np.full(int(cell.max()) + 1, n, np.int64)
            np.minimum.at(least, cell, labels)
            labels = least[cell]
        if np.array_equal(labels, before):
            return labels


def plane_of(positions: np.ndarray) -> tuple[np.ndarray, float] | None:
    """``(n, c)``: the plane n . p = c (n unit) holding every position, within a millionth of
    their extent; None where they do not lie on one plane (or are fewer than three, or not
    finite). A flat mesh cannot shadow itself, and occludes nothing that lies on its light's
    side (:mod:`viewer.passes.shadow`)."""
    pos = np.asarray(positions, np.float64).reshape(-1, 3)
    if len(pos) < 3 or not np.isfinite(pos).all():
        return None
    extent = float(np.max(pos.max(axis=0) - pos.min(axis=0)))
    if not extent > 0.0:
        return None
    centre = pos.mean(axis=0)
    x = pos - centre
    _, vectors = np.linalg.eigh(x.T @ x)
    n = vectors[:, 0]  # the direction of least spread
    if float(np.abs(x @ n).max()) > 1e-6 * extent:
        return None
    return n, float(n @ centre)

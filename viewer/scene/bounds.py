"""World-space bounds of what a scene contains: what shadow maps are fitted to and what a camera
is framed on.

Meshes contribute their vertex bounds. Splat clouds contribute *robust* bounds: a capture carries
far outlier splats (floaters, the background of an unbounded scene) that would make every fit
useless, so a cloud's bounds are the ``[q, 1 - q]`` quantiles of its centres per axis, grown by
the median splat's 3-sigma extent (as splat viewers frame on the bulk of a cloud). Image-space
G-buffer stacks have no world-space geometry and contribute nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SPLAT_QUANTILE = 0.01  # each side: 1 % of the centres per axis may lie outside a cloud's bounds


@dataclass(frozen=True)
class Bounds:
    """An axis-aligned box, world space."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    @property
    def center(self) -> np.ndarray:
        return (np.asarray(self.lo, np.float64) + np.asarray(self.hi, np.float64)) / 2.0

    @property
    def radius(self) -> float:
        """Half the diagonal: the radius of the bounding sphere around :attr:`center`."""
        return float(np.linalg.norm(np.asarray(self.hi) - np.asarray(self.lo)) / 2.0)

    def corners(self) -> np.ndarray:
        """The box's eight corners, ``[8, 3]`` float64."""
        lo, hi = np.asarray(self.lo, np.float64), np.asarray(self.hi, np.float64)
        idx = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], bool)
        return np.where(idx, hi, lo)

    def union(self, other: "Bounds | None") -> "Bounds":
        if other is None:
            return self
        return Bounds(tuple(np.minimum(self.lo, other.lo).tolist()),
                      tuple(np.maximum(self.hi, other.hi).tolist()))


def points_bounds(points: np.ndarray) -> Bounds | None:
    """Bounds of ``[N, 3]`` points (finite ones), or None when there are none."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) == 0:
        return None
    return Bounds(tuple(p.min(axis=0).tolist()), tuple(p.max(axis=0).tolist()))


def splat_bounds(means: np.ndarray, scales: np.ndarray | None = None,
                 quantile: float = SPLAT_QUANTILE) -> Bounds | None:
    """Robust bounds of a splat cloud (module docstring): per-axis quantiles of the centres,
    grown by 3 x the median splat's largest scale (``scales``: ``[N, 3]`` standard deviations)."""
    m = np.asarray(means, np.float64).reshape(-1, 3)
    ok = np.isfinite(m).all(axis=1)
    m = m[ok]
    if len(m) == 0:
        return None
    q = min(max(float(quantile), 0.0), 0.49)
    lo, hi = np.quantile(m, q, axis=0), np.quantile(m, 1.0 - q, axis=0)
    grow = 0.0
    if scales is not None and len(scales):
        s = np.asarray(scales, np.float64).reshape(-1, 3)[ok]
        s = s[np.isfinite(s).all(axis=1)]
        if len(s):
            grow = 3.0 * float(np.median(s.max(axis=1)))
    return Bounds(tuple((lo - grow).tolist()), tuple((hi + grow).tolist()))


def content_bounds(content) -> Bounds | None:
    """Bounds of one object's loaded content (a list of meshes, splats, or an image stack)."""
    if hasattr(content, "means"):  # viewer.splats.data.Splats
        return splat_bounds(content.means, getattr(content, "scales", None))
    if isinstance(content, (list, tuple)):
        out = None
        for mesh in content:
            if hasattr(mesh, "bounds") and getattr(mesh, "vertex_count", 1) > 0:
                lo, hi = mesh.bounds()
                b = Bounds(tuple(np.asarray(lo, float).tolist()),
                           tuple(np.asarray(hi, float).tolist()))
                out = b if out is None else out.union(b)
        return out
    return None  # an image-space stack: no world-space geometry


def scene_bounds(renderer, scene) -> Bounds | None:
    """Bounds of everything ``scene`` contains (through ``renderer``'s geometry cache), or None
    when nothing has world-space geometry."""
    out = None
    for obj in scene.objects:
        b = content_bounds(renderer.geometry(obj))
        if b is not None:
            out = b if out is None else out.union(b)
    return out

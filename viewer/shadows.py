"""Shadow-map frames: where a shadowing light's map looks from and what it covers.

A directional light's map is an orthographic view along the light, fitted to the scene's bounds
(:mod:`viewer.bounds`): the box's corners projected onto the light's axes give the map's extent
in x and y (so no texel is spent outside the scene) and its depth range (so depth precision is
spent only where there is geometry). :class:`ShadowFrame` maps world points to ``(u, v, depth)``
in ``[0, 1]^3`` (depth 0 nearest the light) and carries the numbers the lookups need: the world
size of one texel (normal-offset bias) and the world depth range (slope bias, penumbra width).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bounds import Bounds


@dataclass(frozen=True)
class ShadowFrame:
    matrix: np.ndarray   # [4, 4] float64: world -> (u, v, depth, 1), each in [0, 1] inside
    extent: tuple[float, float]  # world width and height the map covers
    depth_range: float   # world distance from depth 0 to depth 1
    resolution: int      # texels per side

    @property
    def texel_world(self) -> float:
        """World size of one texel (the larger side's)."""
        return max(self.extent) / float(self.resolution)

    def project(self, points: np.ndarray) -> np.ndarray:
        """``[N, 3]`` world points -> ``[N, 3]`` (u, v, depth)."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        h = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ self.matrix.T
        return h[:, :3]


def light_basis(direction) -> np.ndarray:
    """``[3, 3]`` rows: the map's x and y axes and the axis pointing away from the light
    (``-direction``, ``direction`` being the unit vector towards the light)."""
    z = -np.asarray(direction, np.float64)
    z = z / np.linalg.norm(z)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])


def directional_frame(bounds: Bounds, direction, resolution: int = 2048,
                      margin: float = 0.01) -> ShadowFrame:
    """The orthographic frame of a directional light (``direction``: towards the light) fitted
    to ``bounds``, grown by ``margin`` of its size on every side (so filtering at the border
    reads texels of the scene)."""
    basis = light_basis(direction)
    corners = bounds.corners() @ basis.T  # [8, 3] in light space
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    size = np.maximum(hi - lo, 1e-6)
    lo, hi = lo - margin * size, hi + margin * size
    size = hi - lo
    scale = np.diag(1.0 / size)
    m = np.eye(4)
    m[:3, :3] = scale @ basis
    m[:3, 3] = -(scale @ lo)
    return ShadowFrame(matrix=m, extent=(float(size[0]), float(size[1])),
                       depth_range=float(size[2]), resolution=int(resolution))

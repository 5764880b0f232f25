"""Shadow-map frames: where a shadowing light's map looks from and what it covers.

Three kinds, one per light type (the ``SHADOW_*`` constants of ``lib/shadow.glsl``):

* **orthographic** (directional lights, the environment's sun): a view along the light fitted to
  the scene's bounds (:mod:`viewer.scene.bounds`): the box's corners projected onto the light's axes
  give the map's extent in x and y (no texel is spent outside the scene) and its depth range
  (depth precision is spent only where there is geometry);
* **perspective** (spot lights): a square frustum from the light's position along its axis whose
  half-angle is the outer cone's (nothing outside the cone is lit, so nothing outside it needs a
  shadow), near and far planes from the scene's bounds along the axis;
* **cube** (point lights): six 90-degree perspective faces around the light (:class:`ShadowCube`)
  in one atlas texture 3 faces wide and 2 high; the depth stored is the *distance* from the light
  (not the depth along a face's axis), so a direction's depth does not depend on the face that
  holds it.

:class:`ShadowFrame` maps world points to ``(u, v, depth)`` (each in ``[0, 1]`` inside; depth 0
nearest the light) through a 4x4 ``matrix`` to ``(u w, v w, depth, w)`` (``w = 1`` orthographic,
the distance along the axis perspective), and carries what the lookups need: the world size of one
texel (normal-offset bias), the depth range and near plane (penumbra width).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.bounds import Bounds

SHADOW_ORTHO, SHADOW_PERSPECTIVE, SHADOW_CUBE = 1, 2, 3  # lib/shadow.glsl's kinds (0: none)
MAX_SPOT_HALF_ANGLE_DEG = 80.0  # a wider spot's map is clamped to this (tan grows without bound)

# a cube face: the axis it looks along, its map's +u and +v directions (lib/shadow.glsl
# shadow_cube_face and shadow_cube_dir use the same table); atlas tile (face % 3, face // 3)
CUBE_FACES = (((1, 0, 0), (0, 0, -1), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
              ((0, 1, 0), (1, 0, 0), (0, 0, -1)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
              ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (-1, 0, 0), (0, 1, 0)))


@dataclass(frozen=True)
class ShadowFrame:
    matrix: np.ndarray   # [4, 4] float64: world -> (u w, v w, depth, w)
    extent: tuple[float, float]  # orthographic: world width and height; perspective: per unit
    # of distance from the light (2 tan(half-angle) each)
    depth_range: float   # world distance from depth 0 to depth 1
    resolution: int      # texels per side (a cube: per face side)
    kind: int = SHADOW_ORTHO
    near: float = 0.0    # perspective, cube: world distance from the light of depth 0
    # cube faces: the light's position; depth is then the distance from it, not along the axis
    center: tuple[float, float, float] | None = None

    @property
    def texel_world(self) -> float:
        """World size of one texel (the larger side's); perspective and cube frames: per unit of
        distance from the light."""
        return max(self.extent) / float(self.resolution)

    def texel_at(self, bounds) -> float:
        """World size of the smallest texel this frame lays on the box ``bounds`` (lo, hi): an
        orthographic frame's one size; a perspective or cube face's at the box's corner nearest
        the light along its axis (w, the distance along the axis, is affine: its least over a
        box is at a corner), at least ``near`` (a light inside the box: its texels at ``near``)."""
        if self.kind == SHADOW_ORTHO:
            return self.texel_world
        corners = Bounds(*bounds).corners()
        nearest = float((corners @ self.matrix[3, :3] + self.matrix[3, 3]).min())
        return self.texel_world * max(nearest, self.near)

    def project(self, points: np.ndarray) -> np.ndarray:
        """``[N, 3]`` world points -> ``[N, 3]`` (u, v, depth)."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        h = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ self.matrix.T
        out = np.stack([h[:, 0] / h[:, 3], h[:, 1] / h[:, 3], h[:, 2]], axis=1)
        if self.center is not None:
            dist = np.linalg.norm(p - np.asarray(self.center), axis=1)
            out[:, 2] = (dist - self.near) / self.depth_range
        return out

    @property
    def origin(self) -> np.ndarray | None:
        """The light's position: where a perspective frame's u w, v w and w all vanish; None for
        an orthographic frame (a light at infinity)."""
        if self.kind == SHADOW_ORTHO:
            return None
        m = self.matrix[[0, 1, 3]]
        return np.linalg.solve(m[:, :3], -m[:, 3])

    def facing_winding(self) -> str:
        """``"ccw"`` or ``"cw"``: how a triangle that faces the light (counter-clockwise around
        a normal turned towards it) winds in the map, i.e. whether the rasteriser sees the faces
        turned towards the light as its front faces (``"ccw"``) or its back faces."""
        m = self.matrix
        if self.kind == SHADOW_ORTHO:
            c = np.linalg.solve(m[:3, :3], np.full(3, 0.5) - m[:3, 3])  # the frame's middle
            towards = -m[2, :3]
            eps = 1e-3 * max(self.extent)
        else:
            o = self.origin
            axis = m[3, :3] / np.linalg.norm(m[3, :3])
            dist = self.near + 0.5 * self.depth_range
            c = o + axis * dist
            towards = o - c
            eps = 1e-3 * dist
        towards = towards / np.linalg.norm(towards)
        helper = np.array([0.0, 1.0, 0.0]) if abs(towards[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        t = np.cross(helper, towards)
        t /= np.linalg.norm(t)
        b = np.cross(towards, t)  # t x b = towards: the triangle (c, c + t, c + b) faces the light
        uv = self.project(np.stack([c, c + eps * t, c + eps * b]))[:, :2]
        e1, e2 = uv[1] - uv[0], uv[2] - uv[0]
        return "ccw" if e1[0] * e2[1] - e1[1] * e2[0] > 0.0 else "cw"

    def jacobian(self, points: np.ndarray) -> np.ndarray:
        """``[N, 3, 3]``: rows d(u, v, depth)/d(world) at each point (the map's local affine
        approximation: how a splat's covariance projects into it)."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        m = self.matrix
        h = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ m.T
        w = h[:, 3:4]
        du = (m[0, :3][None] - (h[:, 0:1] / w) * m[3, :3][None]) / w
        dv = (m[1, :3][None] - (h[:, 1:2] / w) * m[3, :3][None]) / w
        dd = np.broadcast_to(m[2, :3], du.shape)
        if self.center is not None:
            d = p - np.asarray(self.center)
            dd = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12) / self.depth_range
        return np.stack([du, dv, dd], axis=1)


@dataclass(frozen=True)
class ShadowCube:
    """A point light's six faces (:data:`CUBE_FACES` order), one atlas 3 x 2 faces."""

    faces: tuple[ShadowFrame, ...]
    center: tuple[float, float, float]
    near: float
    depth_range: float
    resolution: int  # texels per face side

    kind = SHADOW_CUBE
    extent = (2.0, 2.0)  # per unit of distance, every face

    @property
    def texel_world(self) -> float:
        return 2.0 / float(self.resolution)

    @property
    def matrix(self) -> np.ndarray:
        """Not used by the lookups (each face's is made in the shader): the identity."""
        return np.eye(4)

    def tile(self, face: int) -> tuple[int, int, int, int]:
        """The atlas viewport (x, y, width, height) of ``face``."""
        n = self.resolution
        return (face % 3 * n, face // 3 * n, n, n)


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


def _near_far(bounds: Bounds, position, axis=None) -> tuple[float, float]:
    """The distances from ``position`` (along ``axis``; without: radially) that bound the box,
    the near one at least 1e-3 of the far one (and 1e-4 world units)."""
    p = np.asarray(position, np.float64)
    corners = bounds.corners() - p
    if axis is None:
        far = float(np.linalg.norm(corners, axis=1).max())
        nearest = np.clip(p, bounds.lo, bounds.hi) - p  # the box's nearest point
        near = float(np.linalg.norm(nearest))
    else:
        along = corners @ np.asarray(axis, np.float64)
        near, far = float(along.min()), float(along.max())
    far = max(far * 1.01, 1e-3)
    near = min(max(near * 0.99, far * 1e-3, 1e-4), far * 0.5)
    return near, far


def _perspective(origin, basis: np.ndarray, tan_half: float, near: float, far: float,
                 resolution: int, center=None) -> ShadowFrame:
    """A square frustum from ``origin`` looking along ``basis[2]`` (rows: map x, map y, axis)."""
    o = np.asarray(origin, np.float64)
    x, y, z = basis
    rng = far - near
    m = np.zeros((4, 4))
    # u w = 0.5 (x.d / tan + z.d), v likewise, depth = (z.d - near) / range, w = z.d (d = p - o)
    m[0, :3] = 0.5 * (x / tan_half + z)
    m[1, :3] = 0.5 * (y / tan_half + z)
    m[2, :3] = z / rng
    m[3, :3] = z
    m[:, 3] = -(m[:, :3] @ o)
    m[2, 3] -= near / rng
    return ShadowFrame(matrix=m, extent=(2.0 * tan_half, 2.0 * tan_half), depth_range=rng,
                       resolution=int(resolution), kind=SHADOW_PERSPECTIVE, near=near,
                       center=None if center is None else tuple(float(v) for v in center))


def spot_frame(bounds: Bounds, position, direction, outer_cone_deg: float,
               resolution: int = 2048, margin: float = 0.02) -> ShadowFrame:
    """The perspective frame of a spot light at ``position`` (``direction``: its axis reversed,
    towards the light): half-angle the outer cone's (at most
    :data:`MAX_SPOT_HALF_ANGLE_DEG`) grown by ``margin``, near and far from ``bounds``."""
    basis = light_basis(direction)
    half = math.radians(min(float(outer_cone_deg), MAX_SPOT_HALF_ANGLE_DEG))
    tan_half = math.tan(half) * (1.0 + margin)
    near, far = _near_far(bounds, position, basis[2])
    return _perspective(position, basis, tan_half, near, far, resolution)


def cube_frames(bounds: Bounds, position, resolution: int = 1024) -> ShadowCube:
    """The six faces of a point light at ``position``, depth the distance from it, near and far
    from ``bounds``."""
    near, far = _near_far(bounds, position)
    faces = tuple(_perspective(position, np.array([r, t, a], np.float64), 1.0, near, far,
                               resolution, center=position) for a, r, t in CUBE_FACES)
    return ShadowCube(faces=faces, center=tuple(float(v) for v in position), near=near,
                      depth_range=far - near, resolution=int(resolution))


# The widest PCSS disc an environment shadow direction gets (radians, 8.6 deg): a median-cut
# region can spread over +-40 deg, and a filter that wide breaks PCSS's assumption of one planar
# blocker (a floor seen edge-on from a direction at the horizon becomes a blocker for every
# receiver whose filter reaches its row of texels: dark blotches low on objects standing on it)
ENV_SHADOW_MAX_RADIUS = 0.15


@dataclass(frozen=True)
class EnvShadowFrames:
    """The environment's shadow directions (:func:`viewer.environment.sampling.median_cut`), each an
    orthographic frame fitted to the scene's bounds, drawn into a tile of one atlas 2 tiles wide
    (the addressing of cascade tiles: ``lib/shadow.glsl`` ``shadow_tile_visibility``).
    ``directions`` unit, world space, towards each light; ``shares`` each one's part of the
    light; ``radii`` angular radii (radians)."""

    faces: tuple[ShadowFrame, ...]
    directions: tuple[tuple[float, float, float], ...]
    shares: tuple[float, ...]
    radii: tuple[float, ...]
    resolution: int  # texels a side of each tile

    kind = SHADOW_ORTHO

    @property
    def count(self) -> int:
        return len(self.faces)

    @property
    def texel_world(self) -> float:
        return max(f.texel_world for f in self.faces)

    @property
    def matrix(self) -> np.ndarray:  # not read: each tile has its own (faces)
        return np.eye(4)

    def penumbra_radius(self, k: int, softness: float = 1.0) -> float:
        """The angular radius (radians) of direction ``k``'s PCSS disc: its region's spread
        times ``softness``, at most :data:`ENV_SHADOW_MAX_RADIUS`."""
        return min(self.radii[k] * float(softness), ENV_SHADOW_MAX_RADIUS)

    def tile(self, k: int) -> tuple[int, int, int, int]:
        """The atlas viewport (x, y, width, height) of direction ``k``."""
        n = self.resolution
        return (k % 2 * n, k // 2 * n, n, n)


def env_shadow_frames(bounds: Bounds, directions, shares, radii,
                      resolution: int) -> EnvShadowFrames:
    """One orthographic frame per direction (world space, towards the light) fitted to
    ``bounds`` (:func:`directional_frame`), ``resolution`` texels a side."""
    dirs = tuple(tuple(float(x) for x in d) for d in directions)
    return EnvShadowFrames(
        faces=tuple(directional_frame(bounds, d, int(resolution)) for d in dirs),
        directions=dirs, shares=tuple(float(x) for x in shares),
        radii=tuple(float(x) for x in radii), resolution=int(resolution))

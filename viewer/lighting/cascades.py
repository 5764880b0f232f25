"""Cascaded shadow maps of directional lights (and the environment's sun) over large scenes.

One orthographic map fitted to the whole scene (:func:`viewer.lighting.shadow_frames.directional_frame`) spends
its texels evenly over the scene: on a 100 m floor a 2048 map's texel is 5 cm, coarse beside the
pixels of what is near the camera. Cascades split the view frustum, clipped to the scene's bounds,
by view depth and give each slice its own map (Filament's and Engel's scheme):

* **when** (:func:`cascade_count`, ``[render] shadow_cascades = "auto"``): the texel of the one
  map is more than :data:`TEXEL_PIXEL_RATIO` times the pixel footprint at the near end of the
  clipped frustum (the depth :data:`NEAR_FRACTION` of the way into it) *and* the first slice's
  bounding sphere is less than :data:`MIN_GAIN` of the map's extent across: otherwise one map
  (today's frame, graph and pixels);
* **splits**: the practical scheme, ``lambda`` (:data:`SPLIT_LAMBDA`) of the logarithmic split
  plus the rest of the uniform one, between the clipped frustum's near and far depths;
* **fit**: each slice's bounding sphere (its size does not change as the camera turns), a square
  of side its diameter (rounded up to a quarter octave, so a small camera move keeps the same
  texel size), its origin snapped to whole texels (the map's texels stay put in the world as the
  camera moves: no shimmer); depth from the whole scene's bounds along the light (every caster
  in front of the slice is drawn).

Every cascade shares the whole-scene frame's light basis and depth mapping (a *square* one here:
:attr:`ShadowCascades.base`); cascade ``k`` is a scale and offset of its (u, v):
``uv_k = (uv - (u0, v0)) * scale`` (``lib/shadow.glsl`` ``shadow_cascade_uv``). The maps are the
tiles of one atlas two tiles wide (tile ``k`` at column ``k % 2``, row ``k // 2``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.bounds import Bounds
from .shadow_frames import SHADOW_ORTHO, ShadowFrame, light_basis

MAX_CASCADES = 4
MAX_TILE = 4096           # texels a side of a cascade's tile at most (the atlas is 2 tiles wide)
SPLIT_LAMBDA = 0.7        # weight of the logarithmic split (the rest: uniform)
TEXEL_PIXEL_RATIO = 2.0   # cascades when one map's texel exceeds this many pixel footprints
NEAR_FRACTION = 0.05      # ... at this fraction of the way into the clipped frustum
MIN_GAIN = 0.25           # ... and the first slice is at most this fraction of the map across
SELECT_MARGIN = 0.02      # a point within this fraction of a tile's edge goes to the next one


@dataclass(frozen=True)
class ShadowCascades:
    """A directional light's cascades: ``base`` the square whole-scene frame (world -> (u, v,
    depth), shared depth), ``boxes`` each cascade's (scale, u0, v0, view depth of its far split),
    ``faces`` each cascade's own frame (``boxes`` applied to ``base``), ``resolution`` texels a
    side of each tile."""

    base: ShadowFrame
    boxes: tuple[tuple[float, float, float, float], ...]
    faces: tuple[ShadowFrame, ...]
    resolution: int

    kind = SHADOW_ORTHO

    @property
    def count(self) -> int:
        return len(self.faces)

    @property
    def matrix(self) -> np.ndarray:
        return self.base.matrix

    @property
    def extent(self) -> tuple[float, float]:
        return self.base.extent

    @property
    def depth_range(self) -> float:
        return self.base.depth_range

    @property
    def texel_world(self) -> float:
        """The base frame's texel (``lib/shadow.glsl`` divides it by each cascade's scale)."""
        return self.base.texel_world

    def tile(self, k: int) -> tuple[int, int, int, int]:
        """The atlas viewport (x, y, width, height) of cascade ``k``."""
        n = self.resolution
        return (k % 2 * n, k // 2 * n, n, n)

    def uniforms(self) -> np.ndarray:
        """``[MAX_CASCADES, 4]`` float32 (scale, u0, v0, 0) per cascade (unused ones: scale 0)."""
        out = np.zeros((MAX_CASCADES, 4), np.float32)
        for k, (s, u0, v0, _) in enumerate(self.boxes):
            out[k] = (s, u0, v0, 0.0)
        return out


def square_frame(bounds: Bounds, direction, resolution: int, margin: float = 0.01
                 ) -> ShadowFrame:
    """:func:`~viewer.lighting.shadow_frames.directional_frame` with a square extent (the larger side's), so
    a cascade's scale is the same along u and v."""
    basis = light_basis(direction)
    corners = bounds.corners() @ basis.T
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    size = np.maximum(hi - lo, 1e-6)
    lo, hi = lo - margin * size, hi + margin * size
    mid = 0.5 * (lo + hi)
    side = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    size = np.array([side, side, hi[2] - lo[2]])
    lo = np.array([mid[0] - side / 2, mid[1] - side / 2, lo[2]])
    scale = np.diag(1.0 / size)
    m = np.eye(4)
    m[:3, :3] = scale @ basis
    m[:3, 3] = -(scale @ lo)
    return ShadowFrame(matrix=m, extent=(side, side), depth_range=float(size[2]),
                       resolution=int(resolution))


def _clip(poly: list, n: np.ndarray, d: float) -> list:
    """Sutherland-Hodgman: the part of the convex polygon ``poly`` where ``n . x + d >= 0``."""
    out = []
    for i, a in enumerate(poly):
        b = poly[(i + 1) % len(poly)]
        da, db = float(n @ a + d), float(n @ b + d)
        if da >= 0.0:
            out.append(a)
        if (da >= 0.0) != (db >= 0.0):
            out.append(a + (b - a) * (da / (da - db)))
    return out


def _faces(corners: np.ndarray) -> list:
    """The six quads of a hexahedron whose corners are indexed by bits (x, y, z) as
    :meth:`viewer.scene.bounds.Bounds.corners` orders them."""
    quads = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))
    return [[corners[i] for i in q] for q in quads]


def view_depths(bounds: Bounds, camera) -> tuple[float, float] | None:
    """The view depths (along the camera's axis) between which the view frustum (near to far
    plane) meets the bounds' box: the depth range of the vertices of their intersection (each
    solid's faces clipped by the other's planes); None where they do not meet."""
    right, up, back = camera.basis()
    o = np.asarray(camera.position, np.float64)
    tx, ty = camera.tan_half_fov()
    near, far = float(camera.near), float(camera.far)
    lo, hi = np.asarray(bounds.lo, np.float64), np.asarray(bounds.hi, np.float64)
    planes = [(-back, float(o @ back) - near), (back, far - float(o @ back))]
    for n in (-tx * back - right, -tx * back + right, -ty * back - up, -ty * back + up):
        planes.append((n, -float(n @ o)))
    box = [(np.eye(3)[i], -lo[i]) for i in range(3)] + [(-np.eye(3)[i], hi[i]) for i in range(3)]
    sign = (-1.0, 1.0)
    frustum = np.array([o + (-back + sign[i >> 2 & 1] * tx * right + sign[i >> 1 & 1] * ty * up)
                        * (far if i & 1 else near) for i in range(8)])
    points = []
    for faces, cuts in ((_faces(bounds.corners()), planes), (_faces(frustum), box)):
        for poly in faces:
            for n, d in cuts:
                if not poly:
                    break
                poly = _clip(poly, n, d)
            points += poly
    if not points:
        return None
    z = (o - np.asarray(points)) @ back
    a = max(float(z.min()), near)
    return a, max(float(z.max()), a * 1.001)


def practical_splits(near: float, far: float, count: int,
                     lam: float = SPLIT_LAMBDA) -> list[float]:
    """``count + 1`` view depths from ``near`` to ``far``: ``lam`` of the logarithmic split plus
    ``1 - lam`` of the uniform one."""
    out = []
    for i in range(count + 1):
        t = i / count
        out.append(lam * near * (far / near) ** t + (1.0 - lam) * (near + (far - near) * t))
    out[0], out[-1] = near, far
    return out


def slice_sphere(camera, a: float, b: float) -> tuple[np.ndarray, float]:
    """The smallest sphere centred on the view axis around the frustum slice between view
    depths ``a`` and ``b``: (world centre, radius)."""
    tx, ty = camera.tan_half_fov()
    k = tx * tx + ty * ty
    c = min(0.5 * (a + b) * (1.0 + k), b)
    r = math.sqrt(max((c - a) ** 2 + k * a * a, (b - c) ** 2 + k * b * b))
    centre = np.asarray(camera.position, np.float64) - camera.basis()[2] * c
    return centre, r


def cascade_count(setting, bounds: Bounds, camera, resolution: int, direction) -> int:
    """How many cascades a directional light gets: ``setting`` 1..4 as given; ``"auto"``: 1, or
    (when one map's texel exceeds :data:`TEXEL_PIXEL_RATIO` pixel footprints at the near end of
    the clipped frustum and the first of 4 slices spans less than :data:`MIN_GAIN` of the map)
    2..4, one more per factor 4 of that texel-to-pixel ratio beyond it."""
    if setting != "auto":
        return int(setting)
    if camera is None:
        return 1
    base = square_frame(bounds, direction, resolution)
    depths = view_depths(bounds, camera)
    if depths is None:  # the camera sees none of the scene
        return 1
    near, far = depths
    z = near + NEAR_FRACTION * (far - near)
    pixel = 2.0 * camera.tan_half_fov()[1] * z / float(camera.height)
    ratio = base.texel_world / max(pixel, 1e-12)
    splits = practical_splits(near, far, MAX_CASCADES)
    _, r = slice_sphere(camera, splits[0], splits[1])
    if ratio <= TEXEL_PIXEL_RATIO or 2.0 * r > MIN_GAIN * base.extent[0]:
        return 1
    return int(min(MAX_CASCADES, 2 + math.floor(math.log(ratio / TEXEL_PIXEL_RATIO, 4.0))))


def cascade_frames(bounds: Bounds, direction, camera, count: int,
                   resolution: int = 2048) -> ShadowCascades:
    """``count`` cascades of a directional light (``direction``: towards it) over the part of
    ``bounds`` that ``camera`` sees, each tile ``resolution`` texels a side."""
    base = square_frame(bounds, direction, resolution)
    extent = base.extent[0]
    n = int(resolution)
    near, far = view_depths(bounds, camera) or (float(camera.near), float(camera.far))
    splits = practical_splits(near, far, count)
    boxes, faces = [], []
    for k in range(count):
        centre, r = slice_sphere(camera, splits[k], splits[k + 1])
        side = 2.0 * r * (1.0 + 4.0 / n)  # a few texels of margin for the filters
        side = min(2.0 ** (math.ceil(4.0 * math.log2(side)) / 4.0), extent)
        texel = side / n / extent  # base uv per cascade texel
        cu, cv = base.project(centre[None])[0, :2]
        u0 = math.floor((cu - 0.5 * side / extent) / texel) * texel
        v0 = math.floor((cv - 0.5 * side / extent) / texel) * texel
        scale = extent / side
        a = np.eye(4)
        a[0, 0] = a[1, 1] = scale
        a[0, 3], a[1, 3] = -u0 * scale, -v0 * scale
        boxes.append((scale, u0, v0, splits[k + 1]))
        faces.append(ShadowFrame(matrix=a @ base.matrix, extent=(side, side),
                                 depth_range=base.depth_range, resolution=n))
    return ShadowCascades(base=base, boxes=tuple(boxes), faces=tuple(faces), resolution=n)

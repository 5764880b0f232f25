"""A camera framed on what an asset shows, and a floor under it (a shadow catcher or a slab).

:func:`frame_camera` looks from a default direction a little above the front (+Z, the glTF front;
:data:`ELEVATION_DEG` up, as model-viewer's default orbit) and fits what it is given to the frame
with a margin, as model-viewer and f3d fill the view: the points of the object's surface (mesh
vertices, splat centres; else the eight corners of its box) are centred in the frame, and the
camera moves back exactly as far as needed for every point to project inside :data:`FILL` of the
frame's half-width and half-height, for the camera's own field of view and aspect. The object's
silhouette then spans 90 % of the frame's limiting side, with an equal 5 % margin either side, and
nothing of it is cut off (a box's corners stick out past a round object's silhouette, so fitting
the box left a helmet a quarter of the frame). Near and far enclose the box (and, when given, what
else should not be clipped: a floor, a cloud's outliers), with far / near at most
:data:`MAX_DEPTH_RATIO`.
"""
from __future__ import annotations

import math

import numpy as np

from .bounds import Bounds
from .camera import Camera
from .material import Material

ELEVATION_DEG = 15.0
AZIMUTH_DEG = 0.0  # from +Z towards +X
FILL = 0.9  # the silhouette spans this share of the frame's limiting side (a 5 % margin each side)
CENTRING_STEPS = 8  # fixed-point steps centring the silhouette (perspective makes it nonlinear)
MAX_DEPTH_RATIO = 1e5
FLOOR_EXTENT = 3.0  # the slab is this x the bounds' larger horizontal side, each way
CATCHER_EXTENT = 6.0  # the catcher: wider, so long shadows fall well inside its fade
FLOOR_MATERIAL = Material(albedo=(0.5, 0.5, 0.5), roughness=0.9)  # the slab: matte mid grey
# the catcher: Lambertian (no specular lobe), so its unshadowed light is albedo / pi x E(+Y)
CATCHER_MATERIAL = Material(albedo=(0.8, 0.8, 0.8), roughness=1.0, specular=0.0)
FLOORS = ("catcher", "slab")


def view_direction(elevation_deg: float = ELEVATION_DEG,
                   azimuth_deg: float = AZIMUTH_DEG) -> np.ndarray:
    """Unit vector from the target towards the camera."""
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])


def frame_camera(bounds: Bounds, fov_y: float, size: tuple[int, int],
                 also: tuple[Bounds, ...] = (), direction: np.ndarray | None = None,
                 points: np.ndarray | None = None) -> Camera:
    """A :class:`Camera` (up +Y) fitted as the module docstring says: to ``points`` (``[N, 3]``
    world space; the ones outside ``bounds`` are left out, as a cloud's outliers are) or, without
    them, to ``bounds``' corners; ``also``: boxes that only widen near and far."""
    d = view_direction() if direction is None else np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    center = bounds.center
    probe = Camera(position=tuple((center + d).tolist()), target=tuple(center.tolist()),
                   fov_y=fov_y, size=size)
    right, up, back = probe.basis()
    tx, ty = probe.tan_half_fov()
    rel = _fitted_points(bounds, points) - center
    x, y, z = rel @ right, rel @ up, rel @ back
    radius = max(bounds.radius, 1e-6)
    shift = np.zeros(2)  # the target's offset along right and up, centring the silhouette
    for _ in range(CENTRING_STEPS):
        dist = _fit_distance(x - shift[0], y - shift[1], z, tx, ty, radius)
        depth = dist - z
        nx, ny = (x - shift[0]) / (depth * tx), (y - shift[1]) / (depth * ty)
        # move the target by the middle of the silhouette's extent, at the depth of the middle
        shift += (0.5 * (nx.max() + nx.min()) * tx * dist,
                  0.5 * (ny.max() + ny.min()) * ty * dist)
    dist = _fit_distance(x - shift[0], y - shift[1], z, tx, ty, radius)
    target = center + shift[0] * right + shift[1] * up
    position = target + d * dist
    depths = dist - (bounds.corners() - center) @ back
    near = 0.5 * float(depths.min()) if depths.min() > 0 else 1e-3 * radius
    far = float(depths.max())
    for box in also:
        far = max(far, float((dist - (box.corners() - center) @ back).max()))
    far = min(max(2.0 * far, near * 4.0), near * MAX_DEPTH_RATIO)
    near, far = max(near, 1e-6), min(max(far, 4e-6), 1e9)  # what a scene file accepts
    return Camera(position=tuple(float(v) for v in position),
                  target=tuple(float(v) for v in target), up=(0.0, 1.0, 0.0),
                  fov_y=float(fov_y), size=(int(size[0]), int(size[1])),
                  near=float(near), far=float(far))


def _fitted_points(bounds: Bounds, points: np.ndarray | None) -> np.ndarray:
    """The points to fit: ``points`` inside ``bounds`` (finite), else the box's corners."""
    if points is not None:
        p = np.asarray(points, np.float64).reshape(-1, 3)
        lo, hi = np.asarray(bounds.lo), np.asarray(bounds.hi)
        p = p[np.isfinite(p).all(axis=1) & ((p >= lo) & (p <= hi)).all(axis=1)]
        if len(p):
            return p
    return bounds.corners()


def _fit_distance(x, y, z, tx: float, ty: float, radius: float) -> float:
    """The camera's distance from the target at which the farthest-reaching point (view-space
    offsets ``x``, ``y`` from the target, ``z`` towards the camera) projects at :data:`FILL`: a
    point at distance D has depth D - z and is inside when |x| <= FILL tx (D - z)."""
    dist = float(np.max(np.maximum(np.abs(x) / (FILL * tx), np.abs(y) / (FILL * ty)) + z))
    return max(dist, 1e-3 * radius)


def floor_object(bounds: Bounds, kind: str = "catcher"):
    """A ``plane`` :class:`~viewer.scene.description.ObjectSpec` (normal +Y) touching the bounds'
    bottom, so shadows have somewhere to fall: :data:`CATCHER_EXTENT` (a catcher) or
    :data:`FLOOR_EXTENT` (a slab) x their larger horizontal side across. ``kind`` (one of :data:`FLOORS`): ``"catcher"`` shows only the shadows
    it receives on the environment, fading into it before its edge
    (:mod:`viewer.passes.ground`); ``"slab"`` is a matte grey plane (:data:`FLOOR_MATERIAL`)."""
    from .description import ObjectSpec

    lo, hi = np.asarray(bounds.lo), np.asarray(bounds.hi)
    side = float(max(hi[0] - lo[0], hi[2] - lo[2], 1e-3 * max(bounds.radius, 1e-6)))
    c = bounds.center
    catcher = kind == "catcher"
    extent = (CATCHER_EXTENT if catcher else FLOOR_EXTENT) * side
    return ObjectSpec(type="plane", center=(float(c[0]), float(lo[1]), float(c[2])),
                      size=(extent, extent), normal=(0.0, 1.0, 0.0),
                      material=CATCHER_MATERIAL if catcher else FLOOR_MATERIAL, catcher=catcher)


def object_bounds(obj) -> Bounds:
    """The world-space box of a ``plane`` object (for near and far)."""
    c = np.asarray(obj.center, np.float64)
    hx, hz = obj.size[0] / 2.0, obj.size[1] / 2.0
    return Bounds((float(c[0] - hx), float(c[1]), float(c[2] - hz)),
                  (float(c[0] + hx), float(c[1]), float(c[2] + hz)))

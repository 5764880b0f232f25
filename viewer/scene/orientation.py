"""Which way is up in an asset file, and the rotation that makes it the scene's +Y.

The scene is +Y up (the environments' zenith, the sky's sun, the floor). An asset whose up is
another axis is rotated by :func:`up_matrix` (a proper rotation: no mirror image). Where the up
axis comes from, first match wins:

1. the user (``--up``);
2. the format: glTF is +Y up by its specification;
3. a marker in the file: a PLY header line ``comment up +Z`` (also ``up_axis``, ``upAxis``,
   ``up-axis``, ``=`` or ``:`` between, sign optional; ``obj_info`` lines too), or a
   ``comment`` naming Blender (its PLY exporter keeps Blender's +Z up by default);
4. splat clouds: :func:`detect_splat_up` - the dominant plane of the flat splats (a capture's
   ground, a table top) is horizontal and the rest of the content is above it;
5. splat clouds and PLY meshes: :func:`detect_shape_up` - an object whose shape is a disc (a
   donut, a plate, a car seen as a whole: two long axes, one short) rests on its broad side, so
   its short axis is up when that axis is a coordinate axis; the side is the one more of its
   surface faces (a capture's cameras see an object's top, not its underside), else the axis's
   own convention (+Z: Blender; Y: the format's sign). Only +Z, +Y and -Y are ever guessed:
   no tool stores -Z or X up, and a guess that lands there is dropped;
6. a convention: COLMAP / 3DGS captures (splats) are y-down (-Y up: upside down with the
   identity), STL is +Z up (CAD and 3D printing), OBJ, OFF and PLY meshes +Y.

Steps 3-6 are said in one line naming the file, what was assumed and ``--up`` (see
:mod:`viewer.scene.assets`).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import InputError

UP_AXES = ("+Y", "+Z", "-Y", "-Z", "+X", "-X")

# world (+Y up) <- file: the row-major 3x3 that maps the file's up axis onto +Y
_ROTATIONS = {
    "+Y": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-Y": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),    # 180 degrees about X (the COLMAP flip)
    "+Z": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),     # -90 degrees about X (Blender -> glTF)
    "-Z": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),     # +90 degrees about X
    "+X": ((0, -1, 0), (1, 0, 0), (0, 0, 1)),     # +90 degrees about Z
    "-X": ((0, 1, 0), (-1, 0, 0), (0, 0, 1)),     # -90 degrees about Z
}

_MARKER = re.compile(r"^(?:comment|obj_info)\s+up(?:[_-]?axis)?\s*[:=]?\s*([+-]?)([xyz])\b",
                     re.IGNORECASE)
FLAT_RATIO = 0.3  # a splat is a disc when its shortest sigma is below this x its middle one
ALIGNED_COS = 0.94  # a disc's normal within ~20 degrees of an axis counts for that axis
MIN_SHARE = 0.25  # the winning axis needs this share of the discs' area
DISC_SHORT = 0.7  # a disc: its short axis's spread below this x the middle one's ...
DISC_ROUND = 0.6  # ... and the middle one's at least this x the long one's (not a rod, a figure)
FACING_SHARE = 0.15  # the surface facing one way along the short axis outweighs the other by this
GUESSABLE = ("+Z", "+Y", "-Y")  # the up axes tools use; a shape that says another one says nothing


def normalize_up(text: str) -> str:
    """``"z"``, ``"+z"``, ``"-Y"`` -> one of :data:`UP_AXES`; anything else is a ValueError."""
    t = str(text).strip().upper()
    t = t if t[:1] in "+-" else "+" + t
    if t not in UP_AXES:
        raise ValueError(f"up must be one of {', '.join(UP_AXES)}, got {text!r}")
    return t


def up_matrix(up: str) -> tuple[tuple[float, ...], ...]:
    """The row-major 4x4 rotation taking ``up`` (one of :data:`UP_AXES`) to +Y, as a scene
    object's ``transform``."""
    r = _ROTATIONS[normalize_up(up)]
    return tuple(tuple(float(v) for v in row) + (0.0,) for row in r) + ((0.0, 0.0, 0.0, 1.0),)


def ply_header(path: str | Path) -> tuple[list[str], dict[str, list[str]]]:
    """The header of a PLY file: its ``comment`` / ``obj_info`` lines and each element's property
    names, read without the body. A file that is not a PLY header is an :class:`InputError`."""
    path = Path(path)
    with path.open("rb") as f:
        head = f.read(1 << 16)
    if not head.startswith(b"ply"):
        raise InputError("not a PLY file (no 'ply' magic line)", where=path)
    end = head.find(b"end_header")
    if end < 0:
        raise InputError("not a readable PLY file: no end_header in its first 64 KiB", where=path)
    comments, elements, current = [], {}, None
    for raw in head[:end].decode("ascii", "replace").splitlines()[1:]:
        words = raw.split()
        if not words:
            continue
        if words[0] in ("comment", "obj_info"):
            comments.append(raw.strip())
        elif words[0] == "element" and len(words) >= 2:
            current = words[1]
            elements[current] = []
        elif words[0] == "property" and current is not None and len(words) >= 3:
            elements[current].append(words[-1])
    return comments, elements


def is_splat_ply(elements: dict[str, list[str]]) -> bool:
    """Whether a PLY header's elements are a Gaussian-splat cloud (any layout of
    :mod:`viewer.splats.ply`) rather than a mesh or a plain point cloud."""
    vertex = set(elements.get("vertex", ()))
    return ("f_dc_0" in vertex or "packed_position" in vertex
            or {"opacity", "scale_0", "rot_0"} <= vertex)


def marked_up(comments: list[str]) -> tuple[str, str] | None:
    """``(up, why)`` from a PLY header's comment lines (module docstring, step 3), or None."""
    for line in comments:
        m = _MARKER.match(line)
        if m:
            return (m.group(1) or "+") + m.group(2).upper(), f"read from its header: {line!r}"
    for line in comments:
        if "blender" in line.lower():
            return "+Z", "assumed: written by Blender, whose PLY exporter keeps +Z up"
    return None


def detect_splat_up(splats) -> tuple[str, str] | None:
    """``(up, why)`` from a cloud's geometry, or None when it does not say.

    Discs (shortest sigma < :data:`FLAT_RATIO` x the middle one) vote for the coordinate axis
    their normal (stored, else the shortest axis) lies along, weighted by opacity x area; the
    axis with the most area (at least :data:`MIN_SHARE` of it) is the dominant plane's normal
    (a capture's ground or table top). Up is the side of that plane's densest slab (the mode of
    the discs' positions along the axis) where the rest of the content lies: the median of the
    other splats. Far outliers are left out first (per-axis 1 % quantiles, as the bounds do).
    """
    from ..splats.data import quat_to_matrix

    means = np.asarray(splats.means, np.float64)
    if len(means) < 16:
        return None
    lo, hi = np.quantile(means, 0.01, axis=0), np.quantile(means, 0.99, axis=0)
    keep = ((means >= lo) & (means <= hi)).all(axis=1)
    means = means[keep]
    scales = np.asarray(splats.scales, np.float64)[keep]
    order = np.argsort(scales, axis=1)
    s_sorted = np.take_along_axis(scales, order, axis=1)
    flat = s_sorted[:, 0] < FLAT_RATIO * s_sorted[:, 1]
    if flat.sum() < 8:
        return None
    rot = quat_to_matrix(np.asarray(splats.rotations, np.float64)[keep][flat])
    shortest = rot[np.arange(len(rot)), :, order[flat, 0]]  # the shortest local axis, world
    stored = np.asarray(splats.normals, np.float64)[keep][flat]
    has = np.linalg.norm(stored, axis=1) > 0.5
    normals = np.where(has[:, None], stored, shortest)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    weight = (np.asarray(splats.opacities, np.float64)[keep][flat]
              * s_sorted[flat, 1] * s_sorted[flat, 2])
    aligned = np.abs(normals) > ALIGNED_COS  # [M, 3]
    votes = (aligned * weight[:, None]).sum(axis=0)
    axis = int(np.argmax(votes))
    if votes[axis] < MIN_SHARE * weight.sum():
        return None
    coord = means[:, axis]
    extent = float(hi[axis] - lo[axis])
    if extent <= 0.0:
        return None
    plane_coords = means[flat][aligned[:, axis], axis]
    hist, edges = np.histogram(plane_coords, bins=32, range=(lo[axis], hi[axis]))
    k = int(np.argmax(hist))
    plane = 0.5 * (edges[k] + edges[k + 1])
    rest = coord[np.abs(coord - plane) > 2.0 * (edges[1] - edges[0])]
    if len(rest) < 0.02 * len(coord) or len(rest) < 4:
        return None  # nothing off the plane: a flat cloud has no up
    side = float(np.median(rest)) - plane
    if abs(side) < 0.05 * extent:
        return None
    up = ("+" if side > 0 else "-") + "XYZ"[axis]
    share = 100.0 * votes[axis] / weight.sum()
    return up, (f"detected: the flat splats' dominant plane ({share:.0f} % of their area: a "
                f"ground, a table) is normal to {'XYZ'[axis]}, the rest of the cloud on its "
                f"{up[0]} side")


def detect_shape_up(points, normals=None, weights=None, y_sign: str = "+",
                    signed: bool = True) -> tuple[str, str] | None:
    """``(up, why)`` from an object's shape (module docstring, step 5), or None when it does not
    say.

    ``points``: ``[N, 3]`` surface samples (splat centres, triangle centroids); ``normals``:
    ``[N, 3]`` their normals (zero rows say nothing) or None; ``signed``: whether the normals'
    sides mean anything (else a normal counts for the side of the centre its point is on);
    ``weights``: ``[N]`` their areas (default 1); ``y_sign``: the format's
    sign for a short Y axis when the surface does not say (``"-"``: COLMAP captures). The
    spread is the weighted principal axes of the points inside the per-axis 1 % quantiles (far
    outliers are left out, as the bounds do)."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    n = len(p)
    w = np.ones(n) if weights is None else np.asarray(weights, np.float64).reshape(n)
    nrm = None if normals is None else np.asarray(normals, np.float64).reshape(n, 3)
    ok = np.isfinite(p).all(axis=1) & np.isfinite(w) & (w > 0)
    if ok.sum() < 16:
        return None
    lo, hi = np.quantile(p[ok], 0.01, axis=0), np.quantile(p[ok], 0.99, axis=0)
    keep = ok & ((p >= lo) & (p <= hi)).all(axis=1)
    p, w = p[keep], w[keep]
    center = (p * w[:, None]).sum(axis=0) / w.sum()
    rel = p - center
    cov = (rel * w[:, None]).T @ rel / w.sum()
    values, vectors = np.linalg.eigh(cov)  # ascending
    spread = np.sqrt(np.maximum(values, 0.0))
    if not (spread[0] < DISC_SHORT * spread[1] and spread[1] >= DISC_ROUND * spread[2]):
        return None
    short = vectors[:, 0]
    axis = int(np.argmax(np.abs(short)))
    if abs(short[axis]) < ALIGNED_COS:
        return None  # tilted: not an object modelled or captured upright in its own frame
    ratio = f"1 : {spread[1] / spread[2]:.2f} : {spread[0] / spread[2]:.2f}"
    why = f"guessed from its shape: a disc (spread {ratio}) resting on its broad side"
    facing = 0.0
    if nrm is not None:
        nrm = nrm[keep]
        nrm = np.where(np.isfinite(nrm), nrm, 0.0)
        along = nrm[:, axis] * w
        if not signed:  # a disc's normal has no side: count it on the side of the centre it is
            along = np.abs(along) * np.sign(rel[:, axis])
        total = np.abs(along).sum()
        facing = float(along.sum() / total) if total > 0 else 0.0
    name = "XYZ"[axis]
    if abs(facing) > FACING_SHARE:
        up = ("+" if facing > 0 else "-") + name
        why += (f", {50 * (1 + abs(facing)):.0f} % of its surface along {name} facing {up} "
                f"(a capture sees an object's top, not its underside)")
    elif name == "Z":
        up = "+Z"
        why += ", short along Z: Blender's +Z up"
    elif name == "Y":
        up = y_sign + "Y"
        why += f", short along Y, taken as {up} (its format's convention)"
    else:
        return None
    return (up, why) if up in GUESSABLE else None


def detect_mesh_up(meshes) -> tuple[str, str] | None:
    """:func:`detect_shape_up` of triangle meshes: their triangles' centroids, normals (from the
    winding) and areas."""
    points, normals, areas = [], [], []
    for mesh in meshes:
        tri = np.asarray(mesh.positions, np.float64)[np.asarray(mesh.indices, np.int64)]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(cross, axis=1)
        points.append(tri.mean(axis=1))
        normals.append(cross / np.maximum(area, 1e-30)[:, None])
        areas.append(area)
    if not points:
        return None
    return detect_shape_up(np.concatenate(points), np.concatenate(normals),
                           np.concatenate(areas))


def detect_cloud_up(splats) -> tuple[str, str] | None:
    """:func:`detect_shape_up` of a splat cloud: its centres, stored normals (else each flat
    splat's shortest axis, which has no side), weighted by opacity x area, COLMAP's -Y when the
    surface does not say."""
    from ..splats.data import quat_to_matrix

    scales = np.asarray(splats.scales, np.float64)
    order = np.argsort(scales, axis=1)
    s_sorted = np.take_along_axis(scales, order, axis=1)
    rot = quat_to_matrix(np.asarray(splats.rotations, np.float64))
    shortest = rot[np.arange(len(rot)), :, order[:, 0]]
    stored = np.asarray(splats.normals, np.float64)
    has = np.linalg.norm(stored, axis=1) > 0.5
    flat = s_sorted[:, 0] < FLAT_RATIO * s_sorted[:, 1]  # a round splat has no normal to tell
    weight = np.asarray(splats.opacities, np.float64) * s_sorted[:, 1] * s_sorted[:, 2]
    if has.mean() > 0.5:
        return detect_shape_up(splats.means, stored * has[:, None], weight, y_sign="-")
    return detect_shape_up(splats.means, shortest * flat[:, None], weight, y_sign="-",
                           signed=False)

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
5. a convention: COLMAP / 3DGS captures (splats) are y-down (-Y up: upside down with the
   identity), STL is +Z up (CAD and 3D printing), OBJ, OFF and PLY meshes +Y.

Steps 3-5 are said in one line naming the file, what was assumed and ``--up`` (see
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
